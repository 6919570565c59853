"""The README's examples are valid: its points CSV, config and [speeds] TOML parse, its FRF table uses the
schema's keys, its `identify --initial` start is the stated 30 % off Table 1, and its Python example runs."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

from millstab.datasets import paper_values
from millstab.io.config import FRF_KEYS, parse_config
from millstab.io.points import read_points

README = (Path(__file__).resolve().parents[1] / "README.md").read_text(encoding="utf-8")


def _blocks(lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", README, flags=re.S)


def test_points_example_parses_as_documented(tmp_path):
    (block,) = _blocks("csv")
    f = tmp_path / "points.csv"
    f.write_text(block, encoding="utf-8")
    pts = read_points(f)
    assert list(pts.label) == ["", "chatter", "stable"]
    assert list(pts.weight) == [2.0, 1.0, 1.0]
    assert pts.boundary.sum() == 1 and pts.rpm[0] == 5500 and pts.depth_mm[0] == 1.20


def test_config_and_speeds_examples_parse():
    blocks = _blocks("toml")
    (config,) = [b for b in blocks if "[cutting]" in b]
    (speeds,) = [b for b in blocks if b.lstrip().startswith("[speeds]")]
    c = parse_config(config + "\n" + speeds)
    assert c.cutting.teeth == 2 and c.structure.x[0].k == pytest.approx(12.53e6)
    assert c.rpm[0] == 3000 and c.rpm[-1] == 15000 and np.allclose(np.diff(c.rpm), 10)


def test_frf_example_uses_the_schema():
    (frf,) = [b for b in _blocks("toml") if "[structure.frf]" in b]
    t = tomllib.loads(frf)["structure"]["frf"]
    assert set(t) <= set(FRF_KEYS) and {"xx", "yy"} <= set(t)
    assert t["yy"] == {"file": "tap.uff", "record": 1}
    assert "**`xy` is the\ndisplacement in x per unit force in y**" in README


def test_identify_start_is_30_percent_off_table_1():
    (line,) = [ln for ln in README.splitlines() if "--initial fn_x=" in ln]
    start = dict(kv.split("=") for kv in re.search(r"--initial (\S+)", line).group(1).split(","))
    truth = paper_values()["input_values"]["ex3"]
    for name, value in start.items():
        assert abs(float(value) / truth[name] - 1) == pytest.approx(0.3, abs=1e-9), name


@pytest.mark.slow
def test_python_example_runs_and_says_what_it_shows(capsys):
    """The "From Python" block runs as written; its CSV is the service's and its fit JSON reads back."""
    (code,) = [b for b in _blocks("python") if "from millstab import api" in b]
    scope: dict = {}
    exec(compile(code, "README.md", "exec"), scope)  # noqa: S102 (our own documentation)
    sld, fit, plan = scope["sld"], scope["fit"], scope["plan"]
    assert sld.csv().splitlines()[0] == "rpm,blim_mm,lobe,chatter_hz"
    assert np.all(np.isfinite(sld.envelope.depth_mm)) and sld.envelope.depth_mm.size == 1001
    assert set(fit.to_json()["parameters"]) == {"fn_x", "k_x", "zeta_x", "fn_y", "k_y", "zeta_y"}
    assert type(fit).from_json(fit.to_json()).estimate.tolist() == fit.estimate.tolist()
    assert plan.rpm.size == 10


def test_the_table_6_line_runs_the_papers_setting(tmp_path, capsys):
    """The README's Monte Carlo line for the paper's Table 6 is a run the code compares with Table 6 (its centre
    and settings; without --preset paper the table is tagged "[other structure]"), here with fewer paths."""
    from millstab.cli import main

    (line,) = [ln for ln in README.splitlines() if ln.startswith("millstab sensitivity mc") and "Table 6" in ln]
    argv = line.split("#")[0].split()[1:]
    argv[argv.index("--n") + 1] = "20"
    argv[argv.index("--out") + 1] = str(tmp_path / "mc.json")
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "mean (paper Table 6)" in out and "[other structure]" not in out and "differs in centre" not in out
