"""Listen to a cut: chatter and its frequency from a microphone or accelerometer recording.

* :func:`listen` -- stable | marginal | chatter, the chatter frequency, a score, the onset time
  (:mod:`millstab.listen.analyze`: every step, threshold and reason).
* :func:`suggest_rpm` -- the spindle speed whose tooth-passing frequency times a whole number is the
  chatter frequency, nearest to the current speed (:mod:`millstab.listen.suggest`).
* :func:`sensor_path` -- the sensor path measured by a tap recorded by the cut's microphone, which
  ``listen(..., tap=)`` divides out when it ranks the chatter family's members (:mod:`millstab.listen.tap`).

Arrays in, results out: reading files is :mod:`millstab.io.recordings`, the command ``millstab listen``.
"""

from millstab.listen.analyze import SCORE_SCALE, Listening, listen
from millstab.listen.suggest import Suggestion, suggest_rpm
from millstab.listen.tap import SensorPath, sensor_path

__all__ = ["SCORE_SCALE", "Listening", "SensorPath", "Suggestion", "listen", "sensor_path", "suggest_rpm"]
