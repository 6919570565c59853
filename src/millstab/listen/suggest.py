"""A new spindle speed from a chatter frequency (the rule of the shop "listen and suggest" tools).

Regenerative chatter is weakest where the teeth meet the wave they left in phase: the tooth-passing
frequency N Ω/60 is the chatter frequency f_c divided by a whole number n (the top of the n-th
stability lobe, to the right of which lies the largest stable pocket). So

    rpm_n = 60 f_c / (N n),   n = 1, 2, ...

and the suggestion is the rpm_n nearest to the current speed within the machine's range. The chatter
frequency moves up a little as the speed changes toward the pocket; one more test cut at the new speed
(and its recording) tells whether to step again. With no rpm_n in the range, reduce the depth.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from millstab.errors import InputError

#: the highest lobe number tried (beyond it the pockets are too narrow to hit)
MAX_LOBE = 40


@dataclass(frozen=True)
class Suggestion:
    """rpm: the suggested speed [rev/min] (NaN: none in range); lobe: n; reason: one sentence."""

    rpm: float
    lobe: int
    reason: str


def suggest_rpm(chatter_hz: float, teeth: int, rpm: float, rpm_range: tuple[float, float] | None = None) -> Suggestion:
    """The speed 60 f_c / (N n) nearest to ``rpm`` within ``rpm_range`` (default 0.5-1.5 × rpm)."""
    lo, hi = rpm_range if rpm_range is not None else (0.5 * rpm, 1.5 * rpm)
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi):
        raise InputError("--rpm-range", f"{lo}:{hi}", "MIN:MAX with 0 < MIN < MAX (rev/min)")
    if not (math.isfinite(chatter_hz) and chatter_hz > 0):
        return Suggestion(float("nan"), 0, "no chatter frequency: keep the speed")
    cands = [(abs(60.0 * chatter_hz / (teeth * n) - rpm), n) for n in range(1, MAX_LOBE + 1)
             if lo <= 60.0 * chatter_hz / (teeth * n) <= hi]
    if not cands:
        return Suggestion(float("nan"), 0, f"no speed 60·{chatter_hz:.1f}/({teeth}·n) lies in {lo:g}-{hi:g} rpm: "
                                           f"reduce the depth instead")
    _, n = min(cands)
    r = 60.0 * chatter_hz / (teeth * n)
    return Suggestion(r, n, f"at {r:.0f} rpm the tooth-passing frequency {teeth}×{r:.0f}/60 = {chatter_hz / n:.1f} Hz "
                            f"is the chatter frequency {chatter_hz:.1f} Hz / {n}: the teeth meet the surface wave "
                            f"in phase (top of lobe {n}); or reduce the depth")
