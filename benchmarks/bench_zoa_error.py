"""How far the zero-order (time-averaged) limits lie from semi-discretization's, by the mean number of teeth in the
cut, N (φ_ex − φ_st) / 2π: the figures behind the warning of a time-averaged decision where under one tooth cuts
(:func:`millstab.stability.time_averaged_note`, docs/updating.md "Decisions for any condition").

For the packaged example tools in their own condition and for the three virtual machines of
``bench_conditions_campaign.py`` (their hammer tests, Kt 700 MPa, Kr 0.3) in a slot, at a/D 0.5 down and up, 0.25 up
and 0.1 down: ln(b_zoa / b_sdm) over ``--speeds`` speeds in ``--rpm`` (SDM's accuracy-controlled default), its median
and its largest value (> 0: the zero-order model allows deeper cuts than the time-domain one, the unsafe side).

Run: ``PYTHONPATH=src:benchmarks .venv/bin/python benchmarks/bench_zoa_error.py`` (~1 min on 2 cores).
"""

from __future__ import annotations

import argparse

import numpy as np
from threadpoolctl import threadpool_limits

from _machine import describe
from bench_conditions_campaign import KR, KT, machines
from millstab.io import load_config
from millstab.model import Cutting
from millstab.stability import sdm, zoa


def row(name: str, structure, cutting: Cutting, rpm: np.ndarray) -> tuple[float, str]:
    r = np.log(zoa.envelope(structure, cutting, rpm).depth_mm / sdm.envelope(structure, cutting, rpm).depth_mm)
    n = cutting.teeth_in_cut
    return n, (f"| {name} | {n:.2f} | {np.median(r):+.3f} | {r.max():+.3f} (×{np.exp(r.max()):.2f}) | "
               f"{np.exp(r.min()):.2f} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rpm", default="5000:12000")
    ap.add_argument("--speeds", type=int, default=29)
    args = ap.parse_args()
    lo, hi = (float(x) for x in args.rpm.split(":"))
    rpm = np.linspace(lo, hi, args.speeds)
    print(describe())
    rows = []
    with threadpool_limits(1):
        for ex in ("ex1", "ex2", "ex3", "fourflute"):
            cfg = load_config(f"example:{ex}")
            rows.append(row(f"{ex} (its config: {cfg.cutting.teeth} teeth)", cfg.structure, cfg.cutting, rpm))
        for name, (hammer, _, teeth) in machines().items():
            for ri, mill in ((1.0, "down"), (0.5, "down"), (0.5, "up"), (0.25, "up"), (0.1, "down")):
                c = Cutting.from_immersion(teeth, KT, KR, ri, mill)
                rows.append(row(f"{name}, {teeth} teeth, {'slot' if ri == 1 else f'a/D {ri} {mill}'}", hammer, c,
                                rpm))
    print(f"ln(b_zoa / b_sdm) over {args.speeds} speeds {lo:g}-{hi:g} rpm, sorted by the teeth in the cut:")
    print("| tool and condition | teeth in the cut | median | largest | smallest ratio |")
    print("|---|---|---|---|---|")
    for _, text in sorted(rows):
        print(text)


if __name__ == "__main__":
    main()
