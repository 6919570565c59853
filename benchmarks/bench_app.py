"""The web app's two speed targets, measured in a real browser (Debian's chromium via Playwright).

1. SLD redraw after a parameter edit, 2 000 speeds (example ex3 with speeds 2000..21990 step 10): time
   from the Enter key in the stiffness field to the second animation frame after the plot's data source
   changed in the browser's Bokeh document (server validation + zero-order SLD + transfer + render).
   Target ≤ 200 ms. Median, min and max of ``--edits`` edits; the SLD's own compute time (api.lobes,
   same speeds, in this process, same moment) for comparison.
2. Identification of 6 parameters (fn, k, zeta in x and y) from 100 boundary points (ex3's true
   structure at 100 speeds with 2 % depth noise, seed 0) starting from a structure 3-30 % off: time
   from the click on "Identify" to the result table in the page, with the number of distinct progress
   lines seen meanwhile. Target ≤ 3 s. The same fit run directly through api.identify for comparison.

The machine is shared: the load average is printed; figures taken under load are upper bounds.
Run: ``.venv/bin/python benchmarks/bench_app.py [--edits 15]`` (needs /usr/bin/chromium and millstab[app]).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).parent))
from _machine import describe  # noqa: E402

from millstab import api  # noqa: E402
from millstab.web import testing as T  # noqa: E402

START = {"structure.x[0].fn": "870 Hz", "structure.x[0].k": "12 N/um", "structure.x[0].zeta": "0.026",
         "structure.y[0].fn": "980 Hz", "structure.y[0].k": "7 N/um", "structure.y[0].zeta": "0.013"}


def points_file(folder: Path) -> Path:
    from millstab.identify.synthetic import example_points

    _, pts = example_points("ex3", n=100, noise=0.02, seed=0)
    path = folder / "ex3_100_points.csv"
    path.write_text("rpm,depth_mm\n" + "".join(f"{r:.10g},{d:.6g}\n" for r, d in zip(pts.rpm, pts.depth_mm)))
    return path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--edits", type=int, default=15)
    args = ap.parse_args()
    if not T.CHROMIUM.exists():
        sys.exit(f"bench_app: no chromium at {T.CHROMIUM}")
    from playwright.sync_api import sync_playwright

    print(describe())
    print(f"load average at start: {os.getloadavg()[0]:.1f} (1 min) on {os.cpu_count()} CPUs")
    with tempfile.TemporaryDirectory() as tmp, threadpool_limits(1), T.running_app() as url, sync_playwright() as p:
        browser = p.chromium.launch(**T.LAUNCH)
        page = browser.new_page(viewport={"width": 1400, "height": 1000})
        page.set_default_timeout(120_000)
        T.open_app(page, url)
        T.set_field(page, "speeds.start", "2000")
        T.set_field(page, "speeds.stop", "21990")
        t_end = time.monotonic() + 60
        while len(T.source_data(page)["rpm"]) != 2000 and time.monotonic() < t_end:
            time.sleep(0.05)
        times = []
        for i in range(args.edits):
            times.append(T.timed_edit(page, "structure.x[0].k", "8 N/um" if i % 2 == 0 else "9 N/um"))
        cfg = api.config("example:ex3")
        rpm = api.speeds("2000:21990:10")
        assert rpm.size == 2000
        api.lobes(cfg, rpm)
        compute = []
        for _ in range(args.edits):
            t0 = time.perf_counter()
            api.lobes(cfg, rpm)
            compute.append(1e3 * (time.perf_counter() - t0))
        print(f"SLD redraw after an edit, 2000 speeds, {args.edits} edits: median {statistics.median(times):.0f} ms "
              f"(min {min(times):.0f}, max {max(times):.0f}); target 200 ms. api.lobes alone: median "
              f"{statistics.median(compute):.1f} ms")

        path = points_file(Path(tmp))
        pts = api.points(path)
        cfg_start = api.config_from_fields({**api.config_fields(cfg), "structure": {
            "x": [{"fn": START["structure.x[0].fn"], "k": START["structure.x[0].k"],
                   "zeta": float(START["structure.x[0].zeta"])}],
            "y": [{"fn": START["structure.y[0].fn"], "k": START["structure.y[0].k"],
                   "zeta": float(START["structure.y[0].zeta"])}]}})
        t0 = time.perf_counter()
        fit = api.identify(cfg_start, pts)  # also loads the compiled kernels, so both runs below are warm
        print(f"the fit through api.identify in this process (cold): {time.perf_counter() - t0:.2f} s (MLAE "
              f"{fit.mlae:.3g} mm)")
        for key, value in START.items():
            T.set_field(page, key, value)
        page.locator(".tool-status").filter(has_text="valid").wait_for()
        T.tab(page, "Identify")
        T.upload(page, "drop-points", path)
        page.locator(".points-note").filter(has_text="100 points").wait_for()
        seen = set()
        t0 = time.perf_counter()
        page.locator(".identify-run button").click()
        while True:
            status = T.text(page, "identify-status")
            if status.startswith("running"):
                seen.add(status.rsplit(" ", 2)[0])  # without the elapsed seconds
            if "done in" in status or "cancelled" in status or "failed" in status:
                break
            time.sleep(0.2)  # the page's own poll is 250 ms; polling it faster only takes CPU from the fit
        page.locator(".fit-table tr").nth(6).wait_for()
        wall = time.perf_counter() - t0
        print(f"identification in the app, 6 parameters from 100 points: {wall:.2f} s click to table "
              f"(page status: {status}); {len(seen)} distinct progress lines seen; target 3 s")
        t0 = time.perf_counter()
        fit = api.identify(cfg_start, pts)
        print(f"the same fit through api.identify in this process (warm, after the app's): "
              f"{time.perf_counter() - t0:.2f} s (MLAE {fit.mlae:.3g} mm)")
        print(f"load average at end: {os.getloadavg()[0]:.1f}")
        browser.close()


if __name__ == "__main__":
    main()
