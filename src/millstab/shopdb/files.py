"""A campaign as plain files, so nothing is locked in the database (``millstab campaign export|import``).

The folder::

    campaign.json             schema millstab.campaign/1: name, machine, tool, who/when, the list of configs,
                              posteriors (parent, config, cut rows used, seed, code version, data hash),
                              recommendations and the event log, each pointing at its file
    config.toml               the current config (that of the newest posterior): `millstab update` reads it
    configs/0001.toml ...     every config text the campaign used, as recorded
    cuts.csv                  every cut in order, the points CSV (`millstab update config.toml cuts.csv`), with
                              the condition columns and stickout_mm of cuts that have their own
    cuts_meta.csv             per cut row: seq, grade, batch, rater, recording, the posterior file that first
                              used it, created_at, created_by
    posteriors/0001.json ...  each posterior, the file `millstab update --out` writes (map/recommend read it)
    recommendations/0001.json ...

Floats are written with their shortest exact repr, so export → import gives back the same numbers.
All writing goes through :mod:`millstab.io` (atomic writes); an export refuses a folder that holds files.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from millstab.errors import InputError
from millstab.io.points import read_points, write_points
from millstab.io.results import atomic_write_text, read_json, write_csv, write_json
from millstab.io.text import read_text
from millstab.points import PointSet

SCHEMA = "millstab.campaign/1"
META = ("seq", "grade", "batch", "rater", "recording", "posterior", "created_at", "created_by")


def _name(kind: str, i: int, ext: str) -> str:
    return f"{kind}/{i + 1:04d}.{ext}"


def export_campaign(store, name: str, folder) -> Path:
    """Write campaign ``name`` of ``store`` into ``folder`` (created; must be empty or new); returns it.

    Raises:
        InputError: no such campaign, or the folder is a file or holds files.
    """
    out = Path(folder)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise InputError("--out", str(out), "must be a new or empty folder (an export never writes over files)")
    b = store.export_bundle(name)
    manifest = {"schema": SCHEMA, **{k: b[k] for k in ("name", "shop", "machine", "tool", "note", "created_at",
                                                        "created_by", "updated_at", "revision")},
                "head": None if b["head"] is None else _name("posteriors", b["head"], "json"),
                "configs": [], "posteriors": [], "recommendations": [], "events": []}
    for i, c in enumerate(b["configs"]):
        atomic_write_text(out / _name("configs", i, "toml"), c["toml"])
        manifest["configs"].append({"file": _name("configs", i, "toml"), "created_at": c["created_at"],
                                    "created_by": c["created_by"]})
    pfile = [_name("posteriors", i, "json") for i in range(len(b["posteriors"]))]
    for i, p in enumerate(b["posteriors"]):
        write_json(out / pfile[i], p["doc"])
        manifest["posteriors"].append({"file": pfile[i], "parent": None if p["parent"] is None else pfile[p["parent"]],
                                       "config": _name("configs", p["config"], "toml"),
                                       **{k: p[k] for k in ("n_rows", "engine", "samples", "seed", "code_version",
                                                            "data_hash", "created_at", "created_by")}})
    rfile = [_name("recommendations", i, "json") for i in range(len(b["recommendations"]))]
    for i, r in enumerate(b["recommendations"]):
        write_json(out / rfile[i], r["doc"])
        manifest["recommendations"].append({"file": rfile[i], "posterior": pfile[r["posterior"]],
                                            "created_at": r["created_at"], "created_by": r["created_by"]})
    for ev in b["events"]:
        manifest["events"].append({k: ev[k] for k in ("at", "user", "action", "detail")}
                                  | {"posterior": None if ev["posterior"] is None else pfile[ev["posterior"]],
                                     "recommendation": None if ev["recommendation"] is None
                                     else rfile[ev["recommendation"]]})
    rows = b["cuts"]
    from millstab.shopdb.store import cuts_from_rows

    if rows:
        write_points(out / "cuts.csv", cuts_from_rows(rows))
    else:
        atomic_write_text(out / "cuts.csv", "rpm,depth_mm,label,weight\n")
    write_csv(out / "cuts_meta.csv", list(META),
              [[r["seq"] for r in rows], [math.nan if r["grade"] is None else r["grade"] for r in rows],
               *[[r[k] for r in rows] for k in ("batch", "rater", "recording")],
               [None if r["posterior"] is None else pfile[r["posterior"]] for r in rows],
               [r["created_at"] for r in rows], [r["created_by"] for r in rows]])
    if b["configs"]:
        current = b["posteriors"][b["head"]]["config"] if b["head"] is not None else len(b["configs"]) - 1
        atomic_write_text(out / "config.toml", b["configs"][current]["toml"])
    write_json(out / "campaign.json", manifest)
    return out


def _index(files: list[str], f, what: str) -> int | None:
    if f is None:
        return None
    if f not in files:
        raise InputError(what, f,
                         f"not one of the exported files ({', '.join(files[:4])}{', ...' if len(files) > 4 else ''})")
    return files.index(f)


def read_campaign(folder) -> dict:
    """The bundle (:meth:`Store.import_bundle`) of an exported campaign folder.

    Raises:
        InputError: not an export folder, a missing file, a reference to no file, cuts and their metadata
            of different lengths.
    """
    src = Path(folder)
    if not (src / "campaign.json").is_file():
        raise InputError("FOLDER", str(src), "not an exported campaign folder (no campaign.json); see docs/shopdb.md")
    m = read_json(src / "campaign.json")
    if not isinstance(m, dict) or m.get("schema") != SCHEMA:
        raise InputError(f"{src / 'campaign.json'} schema", m.get("schema") if isinstance(m, dict) else None,
                         f"expected {SCHEMA!r}")
    cfiles = [c["file"] for c in m["configs"]]
    pfiles = [p["file"] for p in m["posteriors"]]
    rfiles = [r["file"] for r in m["recommendations"]]
    configs = [{"toml": read_text(src / c["file"], c["file"], "TOML text file"), "created_at": c["created_at"],
                "created_by": c["created_by"]} for c in m["configs"]]
    posts = [{"doc": read_json(src / p["file"]), "parent": _index(pfiles, p["parent"], f"{p['file']} parent"),
              "config": _index(cfiles, p["config"], f"{p['file']} config"),
              **{k: p[k] for k in ("n_rows", "engine", "samples", "seed", "code_version", "data_hash", "created_at",
                                   "created_by")}} for p in m["posteriors"]]
    from millstab.update.posterior import Posterior

    for p, f in zip(posts, pfiles):
        Posterior.from_json(p["doc"], f)  # a hand-edited file fails here, not at the next update
    recs = [{"doc": read_json(src / r["file"]), "posterior": _index(pfiles, r["posterior"], f"{r['file']} posterior"),
             "created_at": r["created_at"], "created_by": r["created_by"]} for r in m["recommendations"]]
    text = read_text(src / "cuts_meta.csv", "cuts_meta.csv", "CSV text file")
    meta = list(csv.DictReader(text.splitlines()))
    cuts = read_points(src / "cuts.csv") if meta else PointSet(np.zeros(0), np.zeros(0))
    if len(meta) != len(cuts):
        raise InputError("cuts_meta.csv", f"{len(meta)} rows", f"need one per row of cuts.csv ({len(cuts)})")
    from millstab.shopdb.store import SETTINGS, cut_settings

    own = cut_settings(cuts)  # each cut's own condition and stickout: the columns of cuts.csv
    rows = []
    for i, x in enumerate(meta):
        grade = float(x["grade"]) if x["grade"] else None
        rows.append({"seq": int(x["seq"]), "rpm": float(cuts.rpm[i]), "depth_mm": float(cuts.depth_mm[i]),
                     "label": str(cuts.label[i]), "grade": grade, "weight": float(cuts.weight[i]),
                     "chatter_hz": None if math.isnan(cuts.chatter_hz[i]) else float(cuts.chatter_hz[i]),
                     "batch": x["batch"], "rater": x["rater"], "recording": x["recording"],
                     "posterior": _index(pfiles, x["posterior"] or None, f"cuts_meta.csv row {i + 1} posterior"),
                     "created_at": x["created_at"], "created_by": x["created_by"],
                     **{k: own[i].get(k) for k in SETTINGS}})
    events = [{k: e[k] for k in ("at", "user", "action", "detail")}
              | {"posterior": _index(pfiles, e.get("posterior"), "event posterior"),
                 "recommendation": _index(rfiles, e.get("recommendation"), "event recommendation")}
              for e in m["events"]]
    return {**{k: m.get(k) for k in ("name", "shop", "machine", "tool", "created_at", "created_by", "updated_at",
                                      "revision")},
            "note": m.get("note") or "", "head": _index(pfiles, m.get("head"), "head"), "configs": configs,
            "posteriors": posts, "recommendations": recs, "cuts": rows, "events": events}


def import_campaign(store, folder, name: str | None = None) -> str:
    """Create a campaign in ``store`` from an exported folder (under ``name``, default its own); returns the name."""
    return store.import_bundle(read_campaign(folder), name)


__all__ = ["SCHEMA", "export_campaign", "import_campaign", "read_campaign"]
