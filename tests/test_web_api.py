"""The pieces of the web app that need no browser: the form's round trip through the config validators,
the upload size check, the per-session folder, and that the command line does not import Panel."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from millstab import api
from millstab.datasets import list_examples
from millstab.errors import InputError


@pytest.mark.parametrize("name", list_examples())
def test_form_fields_round_trip_to_the_same_config(name):
    cfg = api.config(f"example:{name}")
    again = api.config_from_fields(api.config_fields(cfg), name)
    c, d = cfg.cutting, again.cutting
    assert (c.teeth, c.kt, c.kr, c.entry, c.exit) == pytest.approx((d.teeth, d.kt, d.kr, d.entry, d.exit), rel=1e-14)
    for direction in ("x", "y"):
        a, b = getattr(cfg.structure, direction), getattr(again.structure, direction)
        assert len(a) == len(b)
        np.testing.assert_allclose([(m.fn, m.k, m.zeta) for m in b], [(m.fn, m.k, m.zeta) for m in a], rtol=1e-14)
    np.testing.assert_allclose(again.rpm, cfg.rpm, rtol=1e-14)


def test_form_field_errors_name_the_field_as_a_file_would():
    t = api.config_fields(api.config("example:ex3"))
    t["structure"]["y"][0]["k"] = "-3 N/um"
    with pytest.raises(InputError) as exc:
        api.config_from_fields(t)
    assert exc.value.field == "structure.y[0].k" and "-3 N/um" in str(exc.value)
    text = api.config_toml(api.config("example:ex3")).replace('k = "10 N/um"', 'k = "-3 N/um"')
    with pytest.raises(InputError) as from_file:
        api.config_from_text(text, "ex3.toml")
    assert str(from_file.value) == str(exc.value)


def test_size_check_refuses_above_the_limit_only():
    api.check_size(api.inputs.MAX_TEXT_BYTES, "ok.csv")
    with pytest.raises(InputError, match="too large"):
        api.check_size(api.inputs.MAX_TEXT_BYTES + 1, "big.csv")
    # a 200 MB upload, without making one: the message names the file, its size and the limit
    with pytest.raises(InputError) as exc:
        api.check_size(200_000_000, "cuts.csv")
    assert "cuts.csv" in str(exc.value) and "200.0 MB" in str(exc.value) and "5 MB" in str(exc.value)
    with pytest.raises(InputError, match="too large"):  # the text parsers check before parsing
        api.points_from_text(b"rpm,depth_mm\n" + b"5000,1\n" * (api.inputs.MAX_TEXT_BYTES // 7 + 1))


def test_uploads_stay_in_the_session_folder():
    pytest.importorskip("panel")
    from millstab.web.state import Session
    from millstab.web.uploads import save_in

    s = Session()
    try:
        for name in ("../../etc/passwd", "/tmp/x.csv", "..", "tap xx (1).csv"):
            p = save_in(s.folder, "xx", name, "freq_hz,real,imag\n")
            assert p.parent == s.folder and p.is_file()
    finally:
        s.close()
    assert not s.folder.exists()


def test_cli_does_not_import_panel_and_checks_the_port():
    code = "import sys, millstab.cli; print('panel' in sys.modules, 'bokeh' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["False", "False"]
    from millstab.cli import main

    assert main(["app", "--port", "70000", "--no-browser"]) == 2
