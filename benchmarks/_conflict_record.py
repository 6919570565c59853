"""What the prior–data conflict check reads, saved per campaign and round, so a new rule can be scored
offline (``benchmarks/score_conflict.py``) without rerunning the campaigns.

One ``.npz`` per benchmark run: ``prior`` (the prior's JSON, :meth:`Prior.to_dict`), and per campaign c
and round k ``c{c}_r{k}_u`` (the posterior samples u = ln θ, float32 (N, P)), ``c{c}_r{k}_noise`` (the
learned noise levels (N, Q), when learned) and ``c{c}_r{k}_cuts`` (rpm, depth [mm], 1 = chatter label, one
row per cut), and ``c{c}_meta`` (JSON: the campaign's truth z and whatever the benchmark adds).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np


def round_record(post) -> dict[str, np.ndarray]:
    """The arrays of one posterior that a conflict rule needs (keys without the campaign/round prefix)."""
    out = {"u": post.u.astype(np.float32)}
    if post.noise is not None:
        out["noise"] = np.asarray(post.noise, np.float32)
    c = post.cuts or {}
    lab = list(c.get("label") or [])
    n = sum(1 for x in lab if x)
    out["cuts"] = np.array([c["rpm"][:n], c["depth_mm"][:n], [x == "chatter" for x in lab[:n]]], float).T
    return out


def campaign_record(c: int, posts: list, meta: dict) -> dict[str, np.ndarray]:
    """Every round's arrays of campaign ``c`` (``posts``: its posteriors in round order) and its meta."""
    out = {f"c{c}_meta": np.array(json.dumps(meta))}
    for k, post in enumerate(posts):
        out |= {f"c{c}_r{k}_{key}": v for key, v in round_record(post).items()}
    return out


def save(path: Path, prior, records: list[dict[str, np.ndarray]]) -> None:
    """Write the prior and the campaigns' records to one compressed ``.npz``."""
    arrays = {"prior": np.array(json.dumps(prior.to_dict()))}
    for r in records:
        arrays |= r
    np.savez_compressed(path, **arrays)


def load(path: Path):
    """(prior, {campaign: {"meta": dict, "rounds": [{"u", "noise", "cuts"} ...]}}) of a saved run."""
    from millstab.update.prior import Prior

    z = np.load(path)
    prior = Prior.from_dict(json.loads(str(z["prior"])))
    camps: dict[int, dict] = {}
    for key in z.files:
        if key == "prior":
            continue
        head, *rest = key.split("_", 2)
        c = int(head[1:])
        d = camps.setdefault(c, {"meta": {}, "rounds": {}})
        if rest[0] == "meta":
            d["meta"] = json.loads(str(z[key]))
        else:
            d["rounds"].setdefault(int(rest[0][1:]), {})[rest[1]] = z[key]
    for d in camps.values():
        d["rounds"] = [d["rounds"][k] for k in sorted(d["rounds"])]
    return prior, dict(sorted(camps.items()))
