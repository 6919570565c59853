"""The report's virtual campaign is computed apart from its prose and checks (issue 26: ``virtual_campaign``
mixed the three): ``play`` returns a :class:`VirtualCampaign`, ``checks`` and ``render`` read only that."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from millstab.reproduce import campaign as rc
from millstab.update.campaign import Campaign


def _played(final_stable: bool = True) -> rc.VirtualCampaign:
    """A campaign of CUTS cuts written by hand: the hammer test's recommendation chatters, the later ones are
    truly stable, the last at 0.9 of the best, the Brier score 0.2 → 0.05."""
    k = rc.CUTS + 1
    stable = (False,) + (True,) * (k - 2) + (final_stable,)
    prod = tuple(np.linspace(0.5, 0.9, k))
    camp = Campaign(cut_rpm=tuple(np.linspace(6000, 9000, rc.CUTS)), cut_depth_mm=(1.0,) * rc.CUTS,
                    labels=("chatter",) + ("stable",) * (rc.CUTS - 1), rec_rpm=tuple(np.linspace(6000, 9000, k)),
                    rec_depth_mm=(2.0,) * k, rec_stable=stable, rec_productivity=prod, best=20000.0, best_exact=22500.0,
                    brier=tuple(np.linspace(0.2, 0.05, k)), stages=(3, 2, 2), posteriors={})
    rpm, depth = np.linspace(*rc.RPM, 5), np.linspace(0.0, rc.MAX_DEPTH_MM, 4)
    maps = {s: np.full((5, 4), 0.5) for s in rc.SHOWN}
    return rc.VirtualCampaign(camp, ("fn_x", "k_x"), np.array([0.01, -0.1]), 400, True, rpm, depth, maps,
                              np.full(5, 3.0), np.full(5, 2.5), 2.75, 7000.0, 2.4, False, 0.8)


def test_checks_come_from_the_played_campaign_alone():
    """The three headline rows by hand: the last recommendation truly stable at 9000 rpm, 2 mm (true limit
    2.75 mm); productivity 0 (the hammer test's chatters) → 0.90, of the exact best 9000·2/22500 = 0.80; Brier
    0.2000 → 0.0500. A final chattering cut fails the first two."""
    rows = rc.checks(_played())
    assert [c.ok for c in rows] == [True, True, True]
    assert rows[0].measured == "9000 rpm, 2.00 mm, true limit 2.75 mm"
    assert rows[1].measured.startswith("0.00 → 0.90 of the best truly stable cut")
    assert "exact best: 0.80" in rows[1].measured
    assert rows[2].measured == "0.2000 → 0.0500"
    assert [c.ok for c in rc.checks(_played(final_stable=False))] == [False, False, True]


def test_render_writes_the_section_without_computing(tmp_path, monkeypatch):
    """``render`` turns a played campaign into the section (table, figure, prose, the same checks) with no engine
    and no posterior: the engines are made unreachable (fails on the old code: there was no played result to
    render, ``virtual_campaign`` computed, wrote and checked in one body)."""
    from millstab import stability
    from millstab.reproduce.report import ReportWriter

    def no_engine(*a, **k):
        raise AssertionError("render computed")

    monkeypatch.setattr(stability, "get_engine", no_engine)
    monkeypatch.setattr(stability, "engine_with", no_engine)
    v = _played()
    w = ReportWriter(tmp_path, "t")
    rc.render(w, v)
    rep = w.write()
    assert rep.checks == tuple(rc.checks(v))
    assert {p.name for p in rep.files} == {"campaign.csv", "fig_campaign.png"}
    md = (tmp_path / "report.md").read_text()
    assert "would cut at 7000 rpm, 2.40 mm: it chatters (0.80 of the best)" in md
    assert "fn_x +1 %, k_x -10 %" in md and "400 posterior samples (--quick" in md
    with pytest.raises(dataclasses.FrozenInstanceError):
        v.ham_ok = True
