"""Where a virtual campaign's time goes (``bench_update_campaign.py --profile``).

Each part's EXCLUSIVE wall and CPU time (a part's children are subtracted: ``recommend`` holds the speed search,
its ``next test`` and ``data guard`` are their own rows), its calls, and the (sample, speed) limits it asked of
the decision module's engine calls (``millstab.update.decide.limits``), per round of the campaign (round k: the
label of cut k, the update with k cuts, the Brier map and the recommendation after k cuts; round 0 is the prior's)
and in all. CPU time is the process's (every numba thread), so CPU / wall says how many cores a part kept busy.

The parts are wrapped where the campaign loop and the decisions look them up (module attributes patched for the
campaign's duration, then restored), so the figures are those of the unchanged code paths.
"""

from __future__ import annotations

import contextlib
import time
from collections import defaultdict
from unittest import mock

import numpy as np

#: the parts that are the bench's own work (judging the tool against its truth), not millstab's campaign
BENCH_PARTS = ("truth: limits", "labels", "Brier map", "coverage and diagnosis", "baselines")
#: the order of the printed rows
ORDER = ("update", "recommend: search", "recommend: data guard", "recommend: confirmed cuts", "recommend: next test",
         *BENCH_PARTS, "other")


class Profile:
    """Exclusive wall/CPU seconds, calls and decision limits per (round, part)."""

    def __init__(self) -> None:
        self.round = 0
        # (round, part) -> [wall, cpu, calls, limits]
        self.parts: dict[tuple[int, str], list] = defaultdict(lambda: [0.0, 0.0, 0, 0])
        self._stack: list[list] = []  # per open part: [name, child wall, child cpu]
        self.t0, self.c0 = time.perf_counter(), time.process_time()
        self.wall = self.cpu = 0.0

    def wrap(self, name: str, fn):
        """``fn`` whose calls count as ``name`` (exclusive of wrapped parts called inside it)."""
        def timed(*a, **kw):
            with self.part(name):
                return fn(*a, **kw)
        return timed

    @contextlib.contextmanager
    def part(self, name: str):
        t0, c0 = time.perf_counter(), time.process_time()
        self._stack.append([name, 0.0, 0.0])
        try:
            yield
        finally:
            dw, dc = time.perf_counter() - t0, time.process_time() - c0
            _, cw, cc = self._stack.pop()
            rec = self.parts[(self.round, name)]
            rec[0] += dw - cw
            rec[1] += dc - cc
            rec[2] += 1
            if self._stack:
                self._stack[-1][1] += dw
                self._stack[-1][2] += dc

    def count_limits(self, fn):
        """``fn`` = ``limits(prior, u, rpm, ...)`` whose (rows × speeds) are added to the open part's count."""
        def counted(prior, u, rpm, *a, **kw):
            if self._stack:
                self.parts[(self.round, self._stack[-1][0])][3] += int(np.shape(u)[0]) * int(np.size(rpm))
            return fn(prior, u, rpm, *a, **kw)
        return counted

    def next_round(self, k: int) -> None:
        """The campaign's ``progress``: the recommendation after k cuts is done; later work is round k + 1."""
        self.round = k + 1

    def stop(self) -> None:
        self.wall, self.cpu = time.perf_counter() - self.t0, time.process_time() - self.c0

    def totals(self) -> dict[str, list]:
        """part -> [wall, cpu, calls, limits] over all rounds, with ``other`` the rest of the campaign's time."""
        out: dict[str, list] = defaultdict(lambda: [0.0, 0.0, 0, 0])
        for (_, name), rec in self.parts.items():
            out[name] = [a + b for a, b in zip(out[name], rec)]
        out["other"] = [self.wall - sum(r[0] for r in out.values()), self.cpu - sum(r[1] for r in out.values()), 0, 0]
        return dict(out)

    def record(self) -> dict:
        """A JSON-able record: totals, and per round {part: [wall, cpu]}."""
        rounds: dict[int, dict] = defaultdict(dict)
        for (k, name), rec in self.parts.items():
            rounds[k][name] = [round(rec[0], 3), round(rec[1], 3)]
        return {"wall": self.wall, "cpu": self.cpu, "totals": self.totals(),
                "rounds": [rounds[k] for k in sorted(rounds)]}


@contextlib.contextmanager
def profiled(prof: Profile):
    """Patch the campaign loop's and the decisions' parts to count in ``prof`` for the duration."""
    import millstab.update.campaign as camp
    import millstab.update.decide as dec

    with contextlib.ExitStack() as stack:
        for mod, attr, name in ((camp, "update", "update"), (camp, "recommend", "recommend: search"),
                                (camp, "brier_score", "Brier map"), (dec, "data_guard", "recommend: data guard"),
                                (dec, "confirmed_cuts", "recommend: confirmed cuts"),
                                (dec, "next_test", "recommend: next test")):
            stack.enter_context(mock.patch.object(mod, attr, prof.wrap(name, getattr(mod, attr))))
        stack.enter_context(mock.patch.object(dec, "limits", prof.count_limits(dec.limits)))
        yield prof


def table(totals: dict[str, list], wall: float, cpu: float, title: str) -> list[str]:
    """The printed rows: part, wall, CPU, CPU/wall, share of the wall time, calls, decision limits."""
    head = (f"    {'part':28s} {'wall s':>8s} {'CPU s':>8s} {'CPU/wall':>8s} {'% wall':>7s} {'calls':>6s} "
            f"{'limits':>9s}")
    lines = [title, head]
    names = [n for n in ORDER if n in totals] + sorted(set(totals) - set(ORDER))
    for n in names:
        w, c, k, lim = totals[n]
        tag = " (bench)" if n in BENCH_PARTS else ""
        lines.append(f"    {n + tag:28s} {w:8.1f} {c:8.1f} {c / w if w > 0.05 else float('nan'):8.2f} "
                     f"{100 * w / max(wall, 1e-9):6.1f}% {k:6d} {lim:9d}")
    own = [totals[n] for n in names if n not in BENCH_PARTS]
    bench = [totals[n] for n in names if n in BENCH_PARTS]
    lines.append(f"    millstab's campaign: {sum(r[0] for r in own):.1f} s wall, {sum(r[1] for r in own):.1f} s CPU; "
                 f"the bench's truth and scoring: {sum(r[0] for r in bench):.1f} s wall, "
                 f"{sum(r[1] for r in bench):.1f} s CPU; all {wall:.1f} s wall, {cpu:.1f} s CPU")
    return lines


def round_lines(record: dict) -> list[str]:
    """One line per round: each part's wall / CPU seconds."""
    out = []
    for k, parts in enumerate(record["rounds"]):
        cells = [f"{n} {parts[n][0]:.1f}/{parts[n][1]:.1f}" for n in ORDER if n in parts]
        out.append(f"    round {k}: " + "; ".join(cells))
    return out


def summed(records: list[dict]) -> tuple[dict[str, list], float, float]:
    """The totals of several campaigns' records, and their wall and CPU seconds."""
    out: dict[str, list] = defaultdict(lambda: [0.0, 0.0, 0, 0])
    for r in records:
        for n, v in r["totals"].items():
            out[n] = [a + b for a, b in zip(out[n], v)]
    return dict(out), sum(r["wall"] for r in records), sum(r["cpu"] for r in records)
