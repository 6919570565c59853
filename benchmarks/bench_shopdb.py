"""Speed of the shop database at shop scale: 10 000 campaigns × 50 cuts in one SQLite file; `history` of one
campaign, of all, and opening a campaign (its current posterior and its cuts), against the issue's 0.2 s.

Fill (bulk inserts, SQLAlchemy Core executemany, 1 000 campaigns a transaction): per campaign a machine (of
100) and a tool (of 500), ``--updates`` updates of ``cuts / updates`` cuts each, every update a posterior row and
an event, plus a create and a recommend event. Filler posteriors are one small real posterior document
(``--post-samples`` prior draws as samples, ~4 KB) stored in every posterior row: the file's size and row
counts are realistic, the documents' contents are not. The campaign that is opened and timed is recorded
through the real path (``Store.record_update``) with a ``--open-samples`` (4 000) sample posterior, the size
``millstab update`` writes by default (~0.5 MB of JSON), and two cuts of their own condition and stickout.

Timed (each ``--repeat`` times, min and median wall time and median CPU time of this process, warm; the file
is in the page cache):
``open_store`` (a new Store: engine + schema check), ``history(campaign)`` (newest 50 events),
``history()`` (newest 50 of all campaigns), the next page (``before=``), opening a campaign
(``snapshot`` + ``Posterior.from_json`` + the cuts' PointSet), the app's opening of it as a user of its shop
(``ShopView.open``: the shop check, the same read and its newest history) and its per-shop list (the campaigns
belong to 20 shops), and, for scale, ``campaigns()`` (all 10 000
rows) and a fresh process running ``millstab history --db FILE --campaign NAME`` (Python start and imports
included: that is what a user waits for at the shell).

Run: ``.venv/bin/python benchmarks/bench_shopdb.py [--campaigns 10000] [--cuts 50] [--updates 5] [--repeat 5]
[--db /tmp/bench_shop.db] [--keep]``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).parent))
from _machine import describe  # noqa: E402

from millstab.io import load_config  # noqa: E402
from millstab.io.examples import example_path as config_path  # noqa: E402
from millstab.points import PointSet  # noqa: E402
from millstab.shopdb import open_store, schema as T  # noqa: E402
from millstab.shopdb.store import code_version, json_text  # noqa: E402
from millstab.update import Posterior, make_prior  # noqa: E402


def _posterior(cfg, cuts: PointSet, n: int, seed: int) -> Posterior:
    pr = make_prior(cfg.structure, cfg.cutting, cfg.prior)
    u = pr.sample(n, np.random.default_rng(seed))
    data = {"rpm": cuts.rpm.tolist(), "depth_mm": cuts.depth_mm.tolist(), "label": cuts.label.tolist(),
            "chatter_hz": [None] * len(cuts)}
    return Posterior(pr, np.exp(u), "zoa", {"stages": 1}, data)


#: the campaigns belong to this many shops (the app's per-shop listing reads one of them)
SHOPS = 20


def fill(store, cfg, toml: str, campaigns: int, cuts: int, updates: int, post_samples: int, seed: int = 0) -> None:
    rng = np.random.default_rng(seed)
    doc = json_text(_posterior(cfg, PointSet(rng.uniform(5e3, 12e3, cuts), rng.uniform(0.5, 5, cuts)),
                               post_samples, seed).to_json())
    ver, at, by = code_version(), "2026-11-20T08:00:00.000000Z", "bench"
    per = cuts // updates
    with store.transaction(write=True) as conn:
        conn.execute(T.machine.insert(), [{"name": f"m{i}", "note": "", "created_at": at, "created_by": by}
                                          for i in range(100)])
        conn.execute(T.tool.insert(), [{"name": f"t{i}", "note": "", "created_at": at, "created_by": by}
                                       for i in range(500)])
    cid = pid = 0
    for block in range(0, campaigns, 1000):
        camp, conf, post, cut, ev = [], [], [], [], []
        for c in range(block, min(block + 1000, campaigns)):
            cid += 1
            camp.append({"id": cid, "name": f"c{c:05d}", "shop": f"s{c % SHOPS}", "machine_id": c % 100 + 1,
                         "tool_id": c % 500 + 1, "note": "",
                         "created_at": at, "created_by": by, "updated_at": at, "revision": updates,
                         "head_posterior_id": pid + updates})
            conf.append({"id": cid, "campaign_id": cid, "sha256": f"{cid:064x}", "toml": toml, "created_at": at,
                         "created_by": by})
            ev.append({"campaign_id": cid, "at": at, "user": by, "action": "create", "detail": f"campaign c{c:05d}"})
            rpm, depth = rng.uniform(5e3, 12e3, cuts), rng.uniform(0.5, 5, cuts)
            for u in range(updates):
                pid += 1
                post.append({"id": pid, "campaign_id": cid, "parent_id": pid - 1 if u else None, "config_id": cid,
                             "n_rows": per * (u + 1), "engine": "zoa", "samples": post_samples, "seed": u,
                             "code_version": ver, "data_hash": "0" * 64, "doc": doc, "created_at": at,
                             "created_by": by})
                for k in range(per * u, per * (u + 1)):
                    cut.append({"campaign_id": cid, "seq": k, "rpm": float(rpm[k]), "depth_mm": float(depth[k]),
                                "label": "chatter" if depth[k] > 2.5 else "stable", "grade": float(depth[k] > 2.5),
                                "weight": 1.0, "chatter_hz": None, "batch": f"day{u}", "rater": "op", "recording": "",
                                "posterior_id": pid, "created_at": at, "created_by": by})
                ev.append({"campaign_id": cid, "at": at, "user": by, "action": "update", "posterior_id": pid,
                           "detail": f"update: +{per} cut(s), {per * (u + 1)} in all"})
            ev.append({"campaign_id": cid, "at": at, "user": by, "action": "recommend", "posterior_id": pid,
                       "detail": "recommend: 9000 rpm, 2.000 mm"})
        with store.transaction(write=True) as conn:
            for table, rows in ((T.campaign, camp), (T.config, conf), (T.posterior, post), (T.cut, cut), (T.event, ev)):
                conn.execute(table.insert(), rows)


def timed(fn, repeat: int) -> tuple[float, float, float, object]:
    """(min wall, median wall, median CPU of this process [s], the last result): on a shared machine the CPU
    time is the figure that does not depend on the other jobs."""
    out, ts, cs = None, [], []
    for _ in range(repeat):
        c0, t0 = time.process_time(), time.perf_counter()
        out = fn()
        ts.append(time.perf_counter() - t0)
        cs.append(time.process_time() - c0)
    return min(ts), statistics.median(ts), statistics.median(cs), out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--campaigns", type=int, default=10_000)
    ap.add_argument("--cuts", type=int, default=50)
    ap.add_argument("--updates", type=int, default=5)
    ap.add_argument("--post-samples", type=int, default=10)
    ap.add_argument("--open-samples", type=int, default=4000)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--db", default="/tmp/bench_shop.db")
    ap.add_argument("--keep", action="store_true", help="keep the database file (else removed at the end)")
    args = ap.parse_args()
    print(describe())
    db = Path(args.db)
    for p in (db, Path(f"{db}-wal"), Path(f"{db}-shm")):
        p.unlink(missing_ok=True)
    cfg = load_config(config_path("ex1"))
    toml = Path(config_path("ex1")).read_text()
    store = open_store(db, user="bench")
    t0 = time.perf_counter()
    fill(store, cfg, toml, args.campaigns, args.cuts, args.updates, args.post_samples)
    t_fill = time.perf_counter() - t0
    # the campaign a user opens: recorded through the real path, with a full-size posterior
    name = f"c{args.campaigns // 2:05d}"
    head = store.head(name)
    # two cuts of their own condition and stickout (migration 0003's columns; the filler cuts are the config's)
    extra = PointSet([9000.0, 9500.0], [2.0, 3.0], ["stable", "chatter"],
                     extra={"stickout_mm": ["60", ""]},
                     conditions={"radial_immersion": [0.25, None], "milling": ["up", ""]})
    every = PointSet(np.r_[store.cuts(name).rpm, extra.rpm], np.r_[store.cuts(name).depth_mm, extra.depth_mm],
                     np.r_[store.cuts(name).label, extra.label])
    store.record_update(name, toml, extra, _posterior(cfg, every, args.open_samples, 1),
                        expected_head=head.posterior_id, expected_rows=head.n_rows, parent=head.posterior_id)
    store.close()
    size = sum(p.stat().st_size for p in (db, Path(f"{db}-wal")) if p.exists()) / 2**20
    print(f"filled {args.campaigns} campaigns × {args.cuts} cuts ({args.updates} updates each, "
          f"{args.campaigns * args.updates} posteriors of {args.post_samples} samples, "
          f"{args.campaigns * (args.updates + 2)} events) in {t_fill:.1f} s; file {size:.0f} MB")

    rows = []
    with threadpool_limits(1):
        *_, store = timed(lambda: open_store(db, user="bench"), 1)  # first open: imports, engine
        rows.append(("open_store (a new Store on the file)",
                     *timed(lambda: open_store(db, user="bench"), args.repeat)[:3]))
        rows.append(("history(campaign) newest 50", *timed(lambda: store.history(name), args.repeat)[:3]))
        rows.append(("history() newest 50 of all", *timed(lambda: store.history(), args.repeat)[:3]))
        page = store.history()
        rows.append(("history() next page (before=)",
                     *timed(lambda: store.history(before=page[-1].id), args.repeat)[:3]))

        def open_campaign():
            snap = store.snapshot(name)
            return snap.posterior(), snap.cuts

        mn, md, cpu, (post, cuts) = timed(open_campaign, args.repeat)
        rows.append((f"open a campaign: posterior ({post.samples.shape[0]} samples) + {len(cuts)} cuts", mn, md, cpu))
        from millstab.api.shop import ShopView

        view = ShopView(db, "bench", [f"s{(args.campaigns // 2) % SHOPS}"])
        mn, md, cpu, oc = timed(lambda: view.open(name), args.repeat)
        rows.append((f"app: ShopView.open (shop check, posterior, {len(oc.cuts)} cuts, history)", mn, md, cpu))
        mn, md, cpu, mine = timed(view.campaigns, args.repeat)
        rows.append((f"app: ShopView.campaigns() of one shop ({len(mine)} rows)", mn, md, cpu))
        rows.append((f"campaigns() all {args.campaigns} rows (not a target)",
                     *timed(store.campaigns, max(1, args.repeat // 2))[:3]))
    env = {**os.environ}
    import resource

    cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", "from millstab.cli import main; main()", "history", "--db", str(db),
                           "--campaign", name], env=env, capture_output=True, text=True)
    t_cli = time.perf_counter() - t0
    cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu_cli = cpu1.ru_utime + cpu1.ru_stime - cpu0.ru_utime - cpu0.ru_stime
    assert done.returncode == 0, done.stderr
    print(f"{'operation':58s} {'min s':>8s} {'median s':>9s} {'CPU s':>8s}   target 0.2 s (wall; CPU: median)")
    for label, mn, md, cpu in rows:
        print(f"{label:58s} {mn:8.4f} {md:9.4f} {cpu:8.4f}")
    print(f"{'millstab history --db FILE --campaign NAME, a new process':58s} {t_cli:8.2f}  wall, {cpu_cli:.2f} s CPU "
          "(Python start + imports)")
    print(f"load average: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    if not args.keep:
        for p in (db, Path(f"{db}-wal"), Path(f"{db}-shm")):
            p.unlink(missing_ok=True)


if __name__ == "__main__":
    main()
