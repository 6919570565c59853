"""The service layer (millstab.api): inputs from text agree with files, the one progress protocol and
cancellation, and the CLI writing exactly what the service returns."""

from __future__ import annotations

import numpy as np
import pytest

from millstab import api
from millstab.cli import main
from millstab.datasets import points_path
from millstab.errors import InputError
from millstab.io import read_points


def test_points_from_text_equal_the_file_reader():
    path = points_path("ex3_points")
    from_file = read_points(path)
    for text in (path.read_text(), path.read_bytes(), b"\xef\xbb\xbf" + path.read_bytes()):  # str, bytes, with a BOM
        up = api.points_from_text(text, "upload.csv")
        for field in ("rpm", "depth_m", "weight"):
            np.testing.assert_array_equal(getattr(up, field), getattr(from_file, field))
        assert list(up.label) == list(from_file.label)


def test_a_table_of_cuts_in_a_notebook_is_read_as_its_csv_file():
    """A DataFrame, {column: values} and a list of row dicts give the file reader's point set, conditions, chatter
    frequencies and empty cells (None, NaN) included; a bad cell gets the file reader's message."""
    path = points_path("ex3_points")
    from_file = read_points(path)
    cols = {"rpm": list(from_file.rpm), "depth_mm": list(from_file.depth_mm), "label": list(from_file.label)}
    rows = [dict(zip(cols, v)) for v in zip(*cols.values())]
    tables = [cols, rows]
    pd = pytest.importorskip("pandas")
    tables.append(pd.DataFrame(cols))
    for table in tables:
        got = api.points(table)
        np.testing.assert_array_equal(got.rpm, from_file.rpm)
        np.testing.assert_array_equal(got.depth_mm, from_file.depth_mm)
        assert list(got.label) == list(from_file.label)
    mixed = api.points(pd.DataFrame({"rpm": [5000, 6000], "depth_mm": [1.5, 2.0], "label": ["stable", "chatter"],
                                     "chatter_hz": [np.nan, 912.5], "radial_immersion": [0.5, None]}))
    np.testing.assert_array_equal(mixed.chatter_hz, [np.nan, 912.5])
    np.testing.assert_array_equal(mixed.conditions["radial_immersion"], [0.5, np.nan])
    with pytest.raises(InputError) as exc:
        api.points([{"rpm": 5000, "depth_mm": "1,5", "label": "stable"}], name="my cuts")
    assert "my cuts line 2" in str(exc.value)
    with pytest.raises(InputError) as exc:
        api.points({"rpm": [5000, 6000], "depth_mm": [1.0]})
    assert "same number of rows" in str(exc.value)
    text = api.points("rpm,depth_mm,label\n5000,1.5,stable\n6000,2,chatter\n")  # CSV text, not a file name
    assert list(text.rpm) == [5000.0, 6000.0] and list(text.label) == ["stable", "chatter"]
    with pytest.raises(InputError) as exc:
        api.points(42)
    assert exc.value.field == "points" and "DataFrame" in str(exc.value)


def test_every_task_takes_a_table_of_cuts_and_names_what_is_no_number():
    """update, predict, validate, identify and design read their cuts as api.points does (a notebook's list of rows:
    AttributeError 'dict' object has no attribute 'has_conditions' from deep in the likelihood before); a text
    sample count and a speed that is no number are InputErrors naming the option, not numpy's TypeError/ValueError."""
    cfg = api.config("example:ex3")
    rows = [{"rpm": 5000, "depth_mm": 1.0, "label": "stable"}, {"rpm": 6000, "depth_mm": 4.0, "label": "chatter"},
            {"rpm": 7000, "depth_mm": 0.5, "label": "stable"}, {"rpm": 8000, "depth_mm": 6.0, "label": "chatter"}]
    cuts = api.points(rows)
    by_rows, by_set = api.update(cfg, rows, samples=100, seed=2), api.update(cfg, cuts, samples=100, seed=2)
    np.testing.assert_array_equal(by_rows.samples, by_set.samples)
    np.testing.assert_array_equal(api.predict(by_set, rows).p_stable, api.predict(by_set, cuts).p_stable)
    with pytest.raises(InputError, match="boundary points"):  # read as a point set: too few boundary points
        api.identify(cfg, rows)
    with pytest.raises(InputError, match="--samples"):
        api.validate(cfg, rows, samples="200")
    with pytest.raises(InputError, match="rpm") as exc:
        api.sensitivity("oat", cfg, ["5000", "x"], eps=[0.1])
    assert "'x'" in str(exc.value)
    with pytest.raises(InputError, match="rpm"):
        api.design(cfg, n=2, rpm=[5000.0, float("nan")])


def test_a_map_refuses_a_depth_or_speed_that_is_no_positive_number_instead_of_returning_nonsense():
    """A NaN depth in p_stable's grid gave P(stable) = -6 .. 0 for every speed (the count of limits above it, off by
    the NaN's place), a negative one P = 1; now each is an InputError naming the grid and the value, as are a text
    speed, a bad seed and a speed range that is not two numbers in recommend."""
    cfg = api.config("example:ex3")
    rows = [{"rpm": 5000, "depth_mm": 1.0, "label": "stable"}, {"rpm": 6000, "depth_mm": 4.0, "label": "chatter"}]
    post = api.update(cfg, rows, samples=100, seed=2)
    rpm = api.speeds("5000:6000:500")
    good = api.p_stable(post, rpm, [1.0, 2.0])
    assert np.all((good >= 0) & (good <= 1))
    assert np.all(api.p_stable(post, rpm, [0.0, 1.0])[:, 0] == 1)  # no cut: stable
    for depth, shown in (([1.0, np.nan], "nan"), ([-1.0, 1.0], "-1"), (["1", "x"], "'x'"), ([], "[]")):
        with pytest.raises(InputError) as exc:
            api.p_stable(post, rpm, depth)
        assert exc.value.field == "depth_mm" and shown in str(exc.value)
    with pytest.raises(InputError, match="rpm"):
        api.p_stable(post, ["5000", "x"], [1.0])
    with pytest.raises(InputError, match="--seed"):
        api.p_stable(post, rpm, [1.0], seed=-1)
    for span in ((5000.0,), "5000:8000", (5000.0, "x")):
        with pytest.raises(InputError, match="--rpm") as exc:
            api.recommend(post, 0.05, span)
        assert "two numbers" in str(exc.value)


def test_numpy_scalars_are_numbers_to_a_recommendation_and_a_text_depth_is_named():
    """np.float32(0.05) (a risk read from an array) was refused as "--risk = 0.05000000074505806 is invalid: must be in
    (0, 1)"; it is the float it holds, and the same answer as 0.05000000074505806 written out. A map's depth axis
    from text is an InputError, not numpy's TypeError."""
    cfg = api.config("example:ex3")
    rows = [{"rpm": 5000, "depth_mm": 1.0, "label": "stable"}, {"rpm": 6000, "depth_mm": 4.0, "label": "chatter"}]
    post = api.update(cfg, rows, samples=100, seed=2)
    a = api.recommend(post, np.float32(0.05), np.array([5000.0, 6000.0]), seed=np.int64(1),
                      max_depth_mm=np.float32(5.0), coarse_points=8)
    b = api.recommend(post, float(np.float32(0.05)), (5000.0, 6000.0), seed=1, max_depth_mm=5.0, coarse_points=8)
    assert a.to_json() == b.to_json()
    for args, field in ((("5",), "--max-depth"), ((5.0, "10"), "depths"), ((5.0, 1), "depths"),
                        ((None,), "--max-depth")):
        with pytest.raises(InputError) as exc:
            api.depth_grid(*args)
        assert exc.value.field == field
    np.testing.assert_array_equal(api.depth_grid(np.float32(2.0), np.int64(4)), [0.5, 1.0, 1.5, 2.0])


@pytest.mark.parametrize("text, field, says", [
    ("rpm,depth\n5000,1\n", "header", "unknown column"),
    ("rpm,depth_mm\n5000,abc\n", "line 2", "number"),
    ("rpm,depth_mm\n5000,1,5\n", "line 2", "decimal comma"),
    (b"rpm,depth_mm\n5000,\xff\xfe1\n", "up.csv", "UTF-8"),
])
def test_bad_uploads_get_the_file_readers_messages(text, field, says):
    with pytest.raises(InputError) as exc:
        api.points_from_text(text, "up.csv")
    assert field in str(exc.value) and says in str(exc.value)


def test_upload_size_is_limited_before_parsing(monkeypatch):
    monkeypatch.setattr("millstab.api.inputs.MAX_TEXT_BYTES", 100)
    with pytest.raises(InputError, match="too large"):
        api.points_from_text(b"rpm,depth_mm\n" + b"5000,1\n" * 20, "big.csv")
    with pytest.raises(InputError, match="too large"):
        api.config_from_text("#" * 101, "big.toml")


def test_config_text_round_trip_gives_the_same_lobes():
    cfg = api.config("example:ex1")
    again = api.config_from_text(api.config_toml(cfg), "ex1.toml")
    rpm = api.speeds("3000:9000:100")
    np.testing.assert_array_equal(api.lobes(cfg, rpm).envelope.depth, api.lobes(again, rpm).envelope.depth)


def test_a_config_from_its_tables_as_a_dict_and_a_wrong_source_named():
    cfg = api.config("example:ex1")
    again = api.config(api.config_fields(cfg))
    assert again.cutting == cfg.cutting and again.structure == cfg.structure
    with pytest.raises(InputError) as exc:
        api.config(42)
    assert exc.value.field == "config" and "a int" in str(exc.value) and "TOML file" in str(exc.value)


def test_every_task_takes_a_config_as_api_config_does_and_lobes_bounds_its_speeds():
    """A notebook writes api.lobes("example:ex1", rpm): it was "'str' object has no attribute 'structure'" from
    inside the task. The tasks read their config through api.config (a name, a file, its tables, a Config), so the
    same config gives the same numbers either way, and a source that is none of these is named; lobes' speeds obey
    the speed bounds (1e9 rpm gave a 1 134 m limit)."""
    cfg = api.config("example:ex1")
    rpm = np.array([5000.0, 6000.0, 7000.0])
    np.testing.assert_array_equal(api.lobes("example:ex1", rpm).envelope.depth, api.lobes(cfg, rpm).envelope.depth)
    np.testing.assert_array_equal(api.envelope(api.config_fields(cfg), rpm).depth, api.envelope(cfg, rpm).depth)
    assert api.modal("example:ex3")[0].structure == api.config("example:ex3").structure
    cuts = [{"rpm": 5000, "depth_mm": 1.0}, {"rpm": 6000, "depth_mm": 3.0}]
    a = api.label_cuts("example:ex1", cuts, revs=20, seed=1)
    b = api.label_cuts(cfg, api.points(cuts), revs=20, seed=1)
    assert list(a.label) == list(b.label)
    for task in (lambda c: api.lobes(c, rpm), lambda c: api.identify(c, "example:ex3_points"),
                 lambda c: api.update(c, cuts, samples=100), lambda c: api.simulate_cut(c, 5000, 1.0)):
        with pytest.raises(InputError) as exc:
            task(42)
        assert exc.value.field == "config"
    with pytest.raises(InputError, match="10..500,000"):
        api.lobes(cfg, [1e9])


@pytest.mark.parametrize("spec, says",
                         [("2000:1000:10", "START < STOP"), ("a:b:c", "numbers"), ("1:2", "START:STOP:STEP"),
                          ([1000.0, -5.0], "> 0"), ([1000.0, np.nan], "> 0"),
                          (["5000", "abc"], "a sequence of numbers"), ({"rpm": 5000}, "a sequence of numbers")])
def test_bad_speeds_name_the_field(spec, says):
    with pytest.raises(InputError) as exc:
        api.speeds(spec)
    assert "--rpm" in str(exc.value) and says in str(exc.value)


@pytest.mark.slow
def test_cli_csv_is_the_services_csv(tmp_path):
    out = tmp_path / "sld.csv"
    assert main(["lobes", "example:ex2", "--rpm", "4000:12000:2000", "--compare", "sdm", "--out", str(out)]) == 0
    result = api.lobes(api.config("example:ex2"), api.speeds("4000:12000:2000"), compare="sdm")
    assert out.read_text() == result.csv()
    header = result.csv().splitlines()[0]
    assert header == "rpm,blim_mm,lobe,chatter_hz,blim_mm_sdm"


def test_a_long_csv_cell_or_a_deeply_nested_toml_is_an_input_error_naming_the_file(tmp_path):
    """Exploratory test (item 5): a CSV cell above the csv module's 131 072-character limit raised csv.Error and TOML
    nested thousands deep raised RecursionError: the page showed nothing (fails on the old code: neither is an
    InputError). Both are one-line InputErrors naming the file (and the CSV's line), from uploads and from files."""
    from millstab.io import load_config
    from millstab.io.frf_files import read_frf_csv
    from millstab.io.speeds import read_rpm_file

    long = "x" * 200_000
    for text in (f"rpm,depth_mm,label\n5000,1,stable\n6000,2,{long}\n",
                 'rpm,depth_mm,label\n5000,1,"stable\n' + "6000,2,chatter\n" * 20_000):  # a quote left open
        with pytest.raises(InputError, match=r"^cuts\.csv line \d+ = 'a cell over 131,072 characters' is invalid: .*"
                                             "quote left open"):
            api.points_from_text(text, "cuts.csv")
    for name, text, read in (("tap.csv", f"freq_hz,real,imag\n100,1,{long}\n", read_frf_csv),
                             ("speeds.csv", f"rpm\n{long}\n", read_rpm_file)):
        (tmp_path / name).write_text(text)
        with pytest.raises(InputError, match=rf"^{name} line 2 = 'a cell over"):
            read(tmp_path / name)
    for deep in ("[" * 5000 + "]" * 5000, "{a = " * 5000 + "1" + "}" * 5000):
        text = f'name = "deep"\nx = {deep}\n'
        with pytest.raises(InputError, match=r"^deep\.toml = 'arrays or inline tables nested too deeply to read'"):
            api.config_from_text(text, "deep.toml")
        (tmp_path / "deep.toml").write_text(text)
        with pytest.raises(InputError, match="nested too deeply") as exc:
            load_config(tmp_path / "deep.toml")
        assert str(tmp_path / "deep.toml") in str(exc.value)


def test_compare_with_itself_is_refused():
    with pytest.raises(InputError, match="must differ"):
        api.lobes(api.config("example:ex1"), api.speeds("3000:4000:100"), engine="zoa", compare="zoa")


@pytest.mark.slow
def test_progress_reports_stage_done_total_and_cancels_sdm():
    cfg = api.config("example:ex1")
    rpm = api.speeds("3000:9000:600")
    calls = []
    api.lobes(cfg, rpm, engine="sdm", progress=lambda *a: calls.append(a))
    assert calls and all(isinstance(s, str) and isinstance(d, int) and t == rpm.size for s, d, t in calls)
    assert calls[0][1] == 0 and calls[-1][1] == rpm.size
    assert [d for _, d, _ in calls] == sorted(d for _, d, _ in calls)

    token = api.CancelToken()

    def cancel_after_first_chunk(stage, done, total):
        if done > 0:
            token.cancel()

    with pytest.raises(api.Cancelled):
        api.lobes(cfg, rpm, engine="sdm", progress=token.watch(cancel_after_first_chunk))


def _stop_at(n: int):
    """(the cancel points met, a check that cancels at the ``n``-th): a user pressing Cancel mid-work."""
    token, seen = api.CancelToken(), []

    def check():
        seen.append(len(seen) + 1)
        if len(seen) >= n:
            token.cancel()
        token.check()
    return seen, check


def test_a_cancel_stops_work_that_reports_no_progress_for_long():
    """Exploratory test (item 1): Cancel was ignored while an update was starting (its first report comes after
    the first tempering stage: 24 s of sdm at 1000 samples) and during a whole map from an sdm posterior (no
    progress at all: it ran 250 s to its end and said "done"). The work now stops at its cancel points
    (millstab.progress.cancel_point: before every engine call, between sdm's compiled chunks) under a thread's
    check (CancelToken.checked, what the app's jobs run in). Fails on the old code: nothing met a cancel point."""
    from millstab.progress import cancel_checked
    from millstab.update.posterior import Posterior
    from millstab.update.stickout import config_prior

    cfg = api.config("example:ex3")
    cuts = api.points_from_text("rpm,depth_mm,label\n7000,0.5,stable\n7000,3,chatter\n14000,1,stable\n", "c.csv")
    seen, check = _stop_at(1)
    reports = []
    with cancel_checked(check), pytest.raises(api.Cancelled):
        api.update(cfg, cuts, samples=100, progress=lambda *a: reports.append(a))
    assert seen == [1] and reports == []  # stopped at its first engine call, before any progress report
    # a map from an sdm posterior: one engine call of 40 samples x 8 speeds, stopped inside it (between chunks)
    prior = config_prior(cfg)
    post = Posterior(prior, np.exp(prior.sample(40, np.random.default_rng(0))), "sdm", cuts={"rpm": [5000, 9000]},
                     engine_options={"steps": 10})
    seen, check = _stop_at(2)
    with cancel_checked(check), pytest.raises(api.Cancelled):
        api.p_stable(post, np.linspace(5000.0, 9000.0, 8), api.depth_grid(3.0, 10), samples="all")
    assert seen == [1, 2]
    token = api.CancelToken()  # the app's form of it: the job's token, on the job's thread
    with token.checked():
        token.cancel()
        with pytest.raises(api.Cancelled):
            api.p_stable(post, np.array([5000.0]), api.depth_grid(3.0, 10))
    api.p_stable(post, np.array([5000.0]), api.depth_grid(3.0, 10))  # outside the block: not checked


def test_identification_reports_progress_and_can_be_cancelled():
    cfg = api.config("example:ex3")
    pts = read_points(points_path("ex3_points"))
    seen = []
    fit = api.identify(cfg, pts, free="fn_x,k_x", progress=lambda s, d, t: seen.append((s, d, t)))
    assert fit.mlae < 0.5 and seen and all(t is None and s.startswith("identify (lsq)") for s, _, t in seen)

    token = api.CancelToken()
    token.cancel()
    with pytest.raises(api.Cancelled):
        api.identify(cfg, pts, free="fn_x,k_x", progress=token.watch())


def test_depth_grid_spans_up_to_the_maximum_and_refuses_nonsense():
    d = api.depth_grid(6.0, 4)
    np.testing.assert_allclose(d, [1.5, 3.0, 4.5, 6.0])
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(InputError, match="> 0 mm"):
            api.depth_grid(bad)


def test_speeds_from_text_numbers_a_file_or_the_config(tmp_path):
    """api.speeds chooses the speeds of every door: --rpm text, an array (a caller's speeds), a speeds file
    (checked there: it was checked by two doors and not a third), the config's [speeds], the fallback."""
    cfg = api.config("example:ex1")
    np.testing.assert_array_equal(api.speeds("5000:5200:100", cfg), [5000.0, 5100.0, 5200.0])
    np.testing.assert_array_equal(api.speeds(np.array([6000.0, 7000.0]), cfg), [6000.0, 7000.0])
    f = tmp_path / "s.csv"
    f.write_text("rpm\n5000\n5500\n", encoding="utf-8")
    np.testing.assert_array_equal(api.speeds(None, cfg, rpm_file=f), [5000.0, 5500.0])
    np.testing.assert_array_equal(api.speeds("", cfg, rpm_file=f), [5000.0, 5500.0])
    with pytest.raises(InputError, match="not both"):
        api.speeds("5000:6000:100", cfg, rpm_file=f)
    f.write_text("rpm\n5000\n0.5\n", encoding="utf-8")
    with pytest.raises(InputError, match="--rpm-file s.csv"):
        api.speeds(None, cfg, rpm_file=f)
    np.testing.assert_array_equal(api.speeds(None, None, (1000.0, 1200.0, 100.0)), [1000.0, 1100.0, 1200.0])


def test_overlay_points_concatenates_the_sets_and_skips_none():
    """The app's SLD overlay (boundary points and labelled cuts as one set) is a service, not door code."""
    pts = read_points(points_path("ex3_points"))
    both = api.overlay_points(None, pts, pts)
    assert np.array_equal(both.rpm, np.concatenate([pts.rpm, pts.rpm]))
    assert np.array_equal(both.depth_mm, np.concatenate([pts.depth_mm, pts.depth_mm]))
    assert list(both.label) == list(pts.label) * 2
    assert api.overlay_points(None, None) is None


def test_an_sld_figure_says_which_cutting_condition_it_is_for():
    """An SLD holds for one cutting condition: its title names it (a/D and direction, or a slot), beside the teeth and
    the coefficients (until 2026-11-29 only "3 teeth, Kt 700 MPa, Kr 0.3": two plots of one tool at a/D 0.3 up and
    0.5 down looked alike); the app's Lobes tab takes the same text."""
    import dataclasses

    import matplotlib

    matplotlib.use("Agg")
    from millstab.model import Cutting

    cfg = api.config("example:ex1")
    assert api.sld_title(cfg) == "ex1: slot, 2 teeth, Kt 556.31 MPa, Kr 0.404"
    c = cfg.cutting
    up = dataclasses.replace(cfg, cutting=Cutting.from_immersion(3, c.kt, c.kr, 0.3, "up"))
    with pytest.warns(UserWarning, match="0.55 teeth in the cut"):  # the zero-order engine there (lobes says so)
        fig = api.lobes(up, np.linspace(5000, 9000, 21)).figure()
    assert fig.axes[0].get_title() == "ex1: a/D 0.3 up milling, 3 teeth, Kt 556.31 MPa, Kr 0.404"
