"""Listen to a cut: chatter and its frequency from a microphone or accelerometer recording.

* :func:`listen` -- stable | marginal | chatter, the chatter frequency, a score, the onset time
  (:mod:`millstab.listen.analyze`: every step, threshold and reason).
* :func:`suggest_rpm` -- the spindle speed whose tooth-passing frequency times a whole number is the
  chatter frequency, nearest to the current speed (:mod:`millstab.listen.suggest`).

Arrays in, results out: reading files is :mod:`millstab.io.recordings`, the command ``millstab listen``.
"""

from millstab.listen.analyze import SCORE_SCALE, Listening, listen
from millstab.listen.suggest import Suggestion, suggest_rpm

__all__ = ["SCORE_SCALE", "Listening", "Suggestion", "listen", "suggest_rpm"]
