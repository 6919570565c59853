"""`millstab predict` (per-cut P(stable) and P(label chatter), input order) and `millstab validate`
(cross-validated scores beside the baselines), each checked against an independent re-computation."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
from scipy.stats import norm
import pytest
from scipy.optimize import minimize

from millstab.cli import main
from millstab.errors import InputError
from millstab.io.points import parse_points
from millstab.model import Cutting, Mode, Structure
from millstab.points import PointSet
from millstab.update import Posterior, make_prior
from millstab.update.likelihood import limits
from millstab.update.validate import (baseline_predictions, cross_validate, fold_indices, scores, speed_groups)

CUT = Cutting(2, 556.31e6, 0.404, 0.0, math.pi)
STRUCT = Structure(x=(Mode(903.0, 12.53e6, 0.03),), y=(Mode(1050.0, 15e6, 0.04),))
PRIOR = make_prior(STRUCT, CUT)


def prior_post(n=300, seed=4, warn=()):
    return Posterior(PRIOR, np.exp(PRIOR.sample(n, np.random.default_rng(seed))), cuts={"rpm": [5000.0, 9000.0]},
                     warnings=tuple(warn))


# --- predict -------------------------------------------------------------------------------------------
@pytest.mark.parametrize("repeated", [False, True])
def test_predict_in_the_input_order_against_each_cuts_own_limits(repeated):
    """``repeated``: a posterior whose rows repeat (as resampling leaves it), evaluated once per distinct row."""
    from millstab.api import predict

    post = prior_post()
    if repeated:
        u = post.u[np.random.default_rng(7).integers(0, 60, 300)]
        post = Posterior(PRIOR, np.exp(u), cuts={"rpm": [5000.0, 9000.0]})
    cuts = parse_points("rpm,depth_mm,label\n9000,2.5,stable\n5000,0.5,chatter\n9000,1.0,\n6100,9.0,0.7\n"
                        "5000,3,stable\n", "c.csv")
    pred = predict(post, cuts)
    eps, fac = post.label_error, post.sigma_depth_factor  # each sample's label model (held values here)
    for i in range(len(cuts)):  # one cut at a time: the fraction of samples whose own limit is above it
        b = limits(PRIOR, post.u, [cuts.rpm[i]])[0][:, 0]
        d = cuts.depth_mm[i]
        assert pred.p_stable[i] == pytest.approx((b > d).mean(), abs=1e-12)
        # the written label: the likelihood's own label model, sample by sample (scipy's normal CDF)
        z = (d - b) / (PRIOR.sigma_depth_mm(np.array([d]))[0] * fac)
        want = np.mean(eps + (1 - 2 * eps) * norm.cdf(z))
        assert pred.p_label_chatter[i] == pytest.approx(want, abs=1e-12)
        assert min(eps.min(), 1 - eps.max()) <= pred.p_label_chatter[i] <= max(1 - eps.min(), eps.max())
    header, cols = pred.table()
    assert header == ["rpm", "depth_mm", "label", "p_stable", "p_label_chatter"]
    # the label column as written: a probability of chatter stays the probability (its grade), not its class
    assert (cols[0].tolist() == [9000, 5000, 9000, 6100, 5000]
            and cols[2] == ["stable", "chatter", "", "0.7", "stable"])
    s = pred.scores()
    g = np.array([0, 1, 0.7, 0])
    m = np.array([0, 1, 3, 4])
    assert s["n"] == 4 and s["brier"] == pytest.approx(np.mean((pred.p_label_chatter[m] - g) ** 2))
    assert s["brier_rate"] == pytest.approx(np.mean((g.mean() - g) ** 2))
    unl = predict(post, PointSet([5000.0], [1.0]))
    assert unl.table()[0] == ["rpm", "depth_mm", "p_stable", "p_label_chatter"] and unl.scores() is None


def test_predict_command(tmp_path, capsys):
    (tmp_path / "post.json").write_text(json.dumps(prior_post(warn=["prior-data conflict: test"]).to_json()))
    (tmp_path / "cuts.csv").write_text("rpm,depth_mm,label,notes\n8000,3,chatter,loud\n5000,0.2,stable,\n")
    assert main(["predict", str(tmp_path / "post.json"), str(tmp_path / "cuts.csv"), "--out",
                 str(tmp_path / "p.csv")]) == 0
    out = capsys.readouterr()
    assert "prior-data conflict" in out.out and "Brier score" in out.out and "ignored columns: notes" in out.err
    rows = list(csv.DictReader((tmp_path / "p.csv").open()))
    assert [float(r["rpm"]) for r in rows] == [8000, 5000] and rows[1]["label"] == "stable"
    post = prior_post()  # P(stable) of the shallow stable cut: the samples' own fraction of limits above it
    want = (limits(PRIOR, post.u, [5000.0])[0][:, 0] > 0.2).mean()
    assert float(rows[1]["p_stable"]) == pytest.approx(want, abs=1e-12) and want > 0.99
    assert 0 <= float(rows[0]["p_label_chatter"]) <= 1
    # outputs are checked before the work: the cuts file is never overwritten
    assert main(["predict", str(tmp_path / "post.json"), str(tmp_path / "cuts.csv"), "--out",
                 str(tmp_path / "cuts.csv")]) == 2
    assert "cuts.csv" in capsys.readouterr().err and "notes" in (tmp_path / "cuts.csv").read_text()


def test_predict_command_writes_the_prediction_json(tmp_path, capsys):
    """`predict --json`: the Prediction document (schema, provenance) beside the CSV, read back by
    Prediction.from_json to the CSV's numbers and to each cut's own fraction of samples above it; --json alone
    writes no CSV; neither output is refused in one line before any work."""
    from millstab.api import Prediction
    from millstab.jsondoc import RESULTS

    post = prior_post()
    (tmp_path / "post.json").write_text(json.dumps(post.to_json()))
    cuts = tmp_path / "cuts.csv"
    cuts.write_text("rpm,depth_mm,label\n8000,3,chatter\n5000,0.2,stable\n6100,1.1,\n")
    base = ["predict", str(tmp_path / "post.json"), str(cuts)]
    assert main(base + ["--out", str(tmp_path / "p.csv"), "--json", str(tmp_path / "p.json")]) == 0
    assert f"wrote {tmp_path / 'p.json'}" in " ".join(capsys.readouterr().out.split())  # rich wraps long lines
    doc = json.loads((tmp_path / "p.json").read_text())
    assert doc["schema"] == Prediction.SCHEMA and ("millstab.api.predict", "Prediction", Prediction.SCHEMA) in RESULTS
    assert doc["points"] == str(cuts)  # provenance: the cuts file it predicted
    pred = Prediction.from_json(doc, "p.json")
    rows = list(csv.DictReader((tmp_path / "p.csv").open()))
    np.testing.assert_allclose(pred.p_stable, [float(r["p_stable"]) for r in rows], rtol=1e-12)
    np.testing.assert_allclose(pred.p_label_chatter, [float(r["p_label_chatter"]) for r in rows], rtol=1e-12)
    assert pred.cuts.rpm.tolist() == [8000, 5000, 6100] and list(pred.cuts.label) == ["chatter", "stable", ""]
    for i, (r, d) in enumerate(zip(pred.cuts.rpm, pred.cuts.depth_mm)):  # independent: samples above the cut
        assert pred.p_stable[i] == pytest.approx((limits(PRIOR, post.u, [r])[0][:, 0] > d).mean(), abs=1e-12)
    assert Prediction.from_json(pred.to_json()).to_json() == pred.to_json()
    assert main(base + ["--json", str(tmp_path / "only.json")]) == 0
    assert (tmp_path / "only.json").exists() and not (tmp_path / "only.csv").exists()
    assert "p_stable" not in capsys.readouterr().out  # --json alone: the table is not printed
    assert main(base + ["--json", str(cuts)]) == 2 and "label" in cuts.read_text()  # never over an input


#: a shop's cuts file: per-cut conditions, notes and operator, two raters, a chatter frequency (cells as written)
SHOP = ("rpm,depth_mm,radial_immersion,milling,notes,operator,label_a,label_b,chatter_hz\n"
        "5000,1.0,,,first pass,ann,stable,stable,\n"
        "5000,4.0,,,loud,bob,chatter,chatter,1010\n"
        "7000,2.0,0.5,down,,ann,stable,0.25,\n"
        '7000,5.0,0.5,down,"burr, marks",bob,chatter,marginal,\n')


def test_predict_keeps_every_input_column_then_the_predictions(tmp_path, capsys):
    """predict --out on a shop's file keeps every column of the cuts in the input order, cells as written (the
    reader's warning says they are "kept, not used"), then p_stable, p_label_chatter, condition and condition_note;
    both probabilities as computed, neither rounded (p_stable of 300 samples is no 3-decimal number); the file
    reads back as the same cuts. Failed before: rpm,depth_mm,label,p_stable,p_label_chatter,condition only."""
    from millstab.api import predict
    from millstab.io import read_points

    post = prior_post()
    (tmp_path / "post.json").write_text(json.dumps(post.to_json()))
    (tmp_path / "cuts.csv").write_text(SHOP)
    assert main(["predict", str(tmp_path / "post.json"), str(tmp_path / "cuts.csv"), "--out",
                 str(tmp_path / "p.csv")]) == 0
    with open(tmp_path / "p.csv", newline="") as fh:
        rows = list(csv.reader(fh))
    head = SHOP.splitlines()[0].split(",")
    assert rows[0] == head + ["p_stable", "p_label_chatter", "condition", "condition_note"]
    body = [r[:len(head)] for r in rows[1:]]
    assert [[float(r[0]), float(r[1])] for r in body] == [[5000, 1], [5000, 4], [7000, 2], [7000, 5]]
    assert [r[2:4] for r in body] == [["", ""], ["", ""], ["0.5", "down"], ["0.5", "down"]]
    assert [r[4:6] for r in body] == [["first pass", "ann"], ["loud", "bob"], ["", "ann"], ["burr, marks", "bob"]]
    assert [r[6:8] for r in body] == [["stable", "stable"], ["chatter", "chatter"], ["stable", "0.25"],
                                      ["chatter", "marginal"]]
    assert [r[8] for r in body] == ["", "1010.0", "", ""]
    cuts = read_points(tmp_path / "cuts.csv")
    pred = predict(post, cuts)
    assert [float(r[len(head)]) for r in rows[1:]] == pred.p_stable.tolist()  # exact: neither column rounded
    assert [float(r[len(head) + 1]) for r in rows[1:]] == pred.p_label_chatter.tolist()
    assert any(abs(p * 1000 - round(p * 1000)) > 1e-6 for p in pred.p_stable)  # k/300: not 3 decimals
    back = read_points(tmp_path / "p.csv")
    np.testing.assert_array_equal(back.ratings, cuts.ratings)
    np.testing.assert_array_equal(back.chatter_hz, cuts.chatter_hz)
    assert back.raters == cuts.raters and list(back.extra["notes"]) == list(cuts.extra["notes"])
    np.testing.assert_array_equal(back.conditions["radial_immersion"], cuts.conditions["radial_immersion"])
    # the JSON document rebuilds the same table
    from millstab.api import Prediction

    again = Prediction.from_json(json.loads(json.dumps(pred.to_json())))
    assert again.table()[0] == pred.table()[0] and again.table()[1][4] == pred.table()[1][4]


def test_predict_without_out_prints_the_table(tmp_path, capsys):
    """predict without --out and --json prints the table as CSV (as simulate does without --out); failed before
    with "error: --out = None is invalid"."""
    (tmp_path / "post.json").write_text(json.dumps(prior_post().to_json()))
    (tmp_path / "cuts.csv").write_text(SHOP)
    base = ["predict", str(tmp_path / "post.json"), str(tmp_path / "cuts.csv")]
    assert main(base) == 0
    printed = capsys.readouterr().out
    assert main(base + ["--out", str(tmp_path / "p.csv")]) == 0
    assert printed.endswith((tmp_path / "p.csv").read_text())


@pytest.mark.filterwarnings("ignore:the zoa engine averages")  # a/D 0.5 down on two teeth: warned, and known here
def test_predict_notes_the_cuts_in_a_condition_never_cut_in_the_words_of_map_and_recommend():
    """A cut whose condition none of the posterior's cuts was made in carries the note of map and recommend
    (one text: millstab.points.never_cut_note, in api.condition_line too): per row in the table and the JSON,
    counted per condition in the summary; none where every row's condition was cut. Failed before: no note."""
    from millstab import api
    from millstab.api import Prediction
    from millstab.points import never_cut_note

    post = prior_post()
    cuts = parse_points("rpm,depth_mm,radial_immersion,milling\n6000,1,,\n6000,1,0.5,down\n7000,2,0.5,down\n", "c.csv")
    pred = api.predict(post, cuts)
    note = never_cut_note(post.trained_conditions)
    assert note == "never cut: the cuts were in slot, 2 teeth"
    half = Cutting.from_immersion(2, CUT.kt, CUT.kr, 0.5, "down")
    assert api.condition_line(post.for_condition(half)) == f"computed for a/D 0.5 down milling, 2 teeth ({note})"
    assert list(pred.note) == ["", note, note]
    header, cols = pred.table()
    assert header[-2:] == ["condition", "condition_note"] and cols[-1] == ["", note, note]
    assert f"2 of 3 cuts in a/D 0.5 down milling, 2 teeth ({note})" in pred.summary()
    back = Prediction.from_json(json.loads(json.dumps(pred.to_json())), "p.json")
    assert list(back.note) == list(pred.note) and "never cut" in back.summary()
    slot = api.predict(post, parse_points("rpm,depth_mm\n6000,1\n", "d.csv"))  # the posterior's own condition
    assert slot.note is None and "condition_note" not in slot.table()[0] and "never cut" not in slot.summary()
    target = api.predict(post.for_condition(half), parse_points("rpm,depth_mm\n6000,1\n", "d.csv"))  # --radial-...
    assert list(target.note) == [note]


@pytest.mark.filterwarnings("ignore:old.csv")  # its columns kept, not used
def test_predict_keeps_an_input_column_named_as_a_prediction():
    """A prediction predicted again: its old p_stable column is kept as input_p_stable, beside the new one (the
    reader refuses a header with a name twice)."""
    from millstab.api import predict

    cuts = parse_points("rpm,depth_mm,p_stable,operator\n6000,1,0.25,ann\n", "old.csv")
    header, cols = predict(prior_post(), cuts).table()
    assert header == ["rpm", "depth_mm", "input_p_stable", "operator", "p_stable", "p_label_chatter"]
    assert cols[2] == ["0.25"] and cols[3] == ["ann"]


# --- validate: the pieces ------------------------------------------------------------------------------
def test_fold_schemes_hold_out_each_cut_once():
    rng = np.random.default_rng(0)
    rpm = np.r_[np.full(4, 5000.0), np.full(3, 5010.0), np.full(5, 7000.0), np.full(2, 9000.0)]
    cuts = PointSet(rpm, rng.uniform(0.5, 4, rpm.size), ["stable"] * rpm.size, batch=["a"] * 7 + ["b"] * 7)
    for scheme in ("random", "speed", "batch"):
        f = fold_indices(cuts, scheme, 3, seed=1)
        assert np.sort(np.concatenate(f)).tolist() == list(range(rpm.size))
    # 5000 and 5010 rpm are one speed (0.2 % apart): three speeds
    sp = fold_indices(cuts, "speed", 5, 1)
    assert sorted(map(len, sp)) == [2, 5, 7]
    assert [len(x) for x in fold_indices(cuts, "batch", 5, 1)] == [7, 7]
    assert fold_indices(cuts, "random", 3, 1)[0].tolist() == fold_indices(cuts, "random", 3, 1)[0].tolist()
    # many speeds: merged into contiguous bands of about equal counts
    many = np.linspace(5000, 9000, 40)
    g = speed_groups(many, 4, max_speeds=10)
    assert np.bincount(g).tolist() == [10, 10, 10, 10] and (np.diff(g) >= 0).all()
    with pytest.raises(InputError, match="scheme"):
        fold_indices(cuts, "day", 3, 1)
    # leave one condition out: each condition's cuts are one fold, whatever their order in the file
    cond = np.array([0, 1, 0, 2, 1, 0, 0, 2, 2, 1, 0, 0, 1, 2])
    f = fold_indices(cuts, "condition", 3, 1, condition=cond)
    assert [x.tolist() for x in f] == [np.flatnonzero(cond == c).tolist() for c in range(3)]
    with pytest.raises(InputError, match="condition"):
        fold_indices(cuts, "condition", 3, 1)  # without each cut's condition


def test_baselines_against_brute_force():
    rng = np.random.default_rng(3)
    n = 30
    rpm, depth = rng.uniform(5000, 9000, n), rng.uniform(0.5, 4, n)
    grade = np.clip(np.round((depth - 2 + rng.normal(0, 0.7, n)) / 1.5 * 2) / 2, 0, 1)  # 0, ½, 1
    train = PointSet(rpm, depth, np.where(grade > 0.6, "chatter", np.where(grade < 0.4, "stable", "marginal")),
                     grade=grade)
    test = PointSet([6000.0, 8000.0, 7000.0], [1.0, 3.5, 2.2])
    got = baseline_predictions(train, test)
    assert got["majority"] == pytest.approx(np.full(3, grade.mean()))
    # standardised features (population sd, as StandardScaler)
    mu, sd = np.array([rpm.mean(), depth.mean()]), np.array([rpm.std(), depth.std()])
    x = (np.column_stack([rpm, depth]) - mu) / sd
    xt = (np.column_stack([test.rpm, test.depth_mm]) - mu) / sd
    logistic, knn = _brute_baselines(x, xt, grade, 5)  # k = round(sqrt(30)) = 5
    np.testing.assert_allclose(got["logistic"], logistic, atol=2e-4)
    np.testing.assert_allclose(got["knn"], knn, atol=1e-12)


def _brute_baselines(x: np.ndarray, xt: np.ndarray, grade: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The two baselines recomputed on standardised features x (train) and xt (test): logistic regression as the
    graded log-likelihood with the L2 penalty ½|w|² (C = 1) minimised directly, and the mean grade of the k nearest
    training cuts by Euclidean distance."""
    def nll(beta):
        z = beta[0] + x @ beta[1:]
        return -(grade * -np.logaddexp(0, -z) + (1 - grade) * -np.logaddexp(0, z)).sum() + 0.5 * beta[1:] @ beta[1:]

    beta = minimize(nll, np.zeros(x.shape[1] + 1), method="BFGS", options={"gtol": 1e-10}).x
    d = np.linalg.norm(x[None, :, :] - xt[:, None, :], axis=2)
    return 1 / (1 + np.exp(-(beta[0] + xt @ beta[1:]))), np.array([grade[np.argsort(row)[:k]].mean() for row in d])


def _slot_and_half(n: int, seed: int = 1) -> PointSet:
    """n cuts alternating slot (empty cells: the config's) and a/D 0.5 down; the slots chatter above 1.5 mm, the
    half-width cuts never: the condition, not speed or depth, tells most of them apart."""
    rng = np.random.default_rng(seed)
    rpm, depth = rng.uniform(5000, 9000, n), rng.uniform(1, 4, n)
    half = np.arange(n) % 2 == 1
    lab = np.where(half | (depth < 1.5), "stable", "chatter")
    return PointSet(rpm, depth, lab, conditions={"radial_immersion": np.where(half, 0.5, np.nan),
                                                 "milling": np.where(half, "down", "")})


def test_baselines_see_the_cutting_condition_where_the_cuts_conditions_differ():
    """On (rpm, depth) alone a slot and a half-width cut at one speed and depth are one point to the baselines;
    given the config's cutting they see each cut's entry angle (the one condition feature that differs here:
    entry 0° slot, 90° down at a/D 0.5; exit 180° both), standardised like rpm and depth: logistic and kNN against
    brute force on those three features. Failed before: baseline_predictions took no condition."""
    from millstab.update.validate import baseline_features

    train = _slot_and_half(24)
    test = PointSet([7000.0, 7000.0], [3.0, 3.0], conditions={"radial_immersion": [np.nan, 0.5],
                                                              "milling": ["", "down"]})
    blind = baseline_predictions(train, test)  # as before: rpm and depth only
    assert blind["logistic"][0] == blind["logistic"][1] and blind["knn"][0] == blind["knn"][1]
    assert baseline_features(train, CUT) == ("rpm", "depth_mm", "entry_deg")
    got = baseline_predictions(train, test, CUT)
    assert got["logistic"][0] > 0.5 > got["logistic"][1] and got["knn"][0] > got["knn"][1]
    g = train.grade
    feats = np.column_stack([train.rpm, train.depth_mm, np.where(np.arange(24) % 2 == 1, 90.0, 0.0)])
    mu, sd = feats.mean(axis=0), feats.std(axis=0)
    x = (feats - mu) / sd
    xt = (np.array([[7000.0, 3.0, 0.0], [7000.0, 3.0, 90.0]]) - mu) / sd
    logistic, knn = _brute_baselines(x, xt, g, 5)  # k = round(√24)
    np.testing.assert_allclose(got["logistic"], logistic, atol=2e-4)
    np.testing.assert_allclose(got["knn"], knn, atol=1e-12)
    # one condition: (rpm, depth) as before; up and down mixed: both angles; another number of teeth: teeth
    assert baseline_features(train.subset(np.arange(24) % 2 == 0), CUT) == ("rpm", "depth_mm")
    np.testing.assert_array_equal(baseline_predictions(train.subset(np.arange(24) % 2 == 0), test, CUT)["knn"],
                                  baseline_predictions(train.subset(np.arange(24) % 2 == 0), test)["knn"])
    mixed = PointSet([5000.0, 6000.0, 7000.0], [1.0, 2.0, 3.0], ["stable"] * 3,
                     conditions={"radial_immersion": [0.5, 0.5, np.nan], "milling": ["up", "down", ""],
                                 "teeth": [np.nan, np.nan, 4]})
    assert baseline_features(mixed, CUT) == ("rpm", "depth_mm", "entry_deg", "exit_deg", "teeth")


def test_cross_validate_keeps_the_conditions_and_warns_as_update_does():
    """validate on cuts in several conditions: its per-cut table and its JSON's cuts keep the condition columns as
    read (empty = the config's), its settings name the baselines' features, and with the zero-order engine it warns
    once for the cuts made with less than one tooth in the cut, as update does (its folds' updates are quiet).
    Failed before: no condition columns, no warning."""
    import warnings

    text = ("rpm,depth_mm,label,radial_immersion,milling,operator\n5000,1,stable,,,ann\n5000,4,chatter,,,bob\n"
            "6000,2,stable,0.1,down,ann\n6000,6,chatter,0.1,down,bob\n7000,1.5,stable,,,ann\n7000,5,chatter,0.1,down,"
            "ann\n")
    cuts = parse_points(text, "shop.csv")

    def fake_update(cfg, train, **kw):
        return prior_post(150, seed=kw["seed"] % 97)

    class Cfg:
        structure, cutting = STRUCT, CUT

    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        res = cross_validate(Cfg(), cuts, n_folds=2, seed=0, samples=150, update_fn=fake_update)
    mine = [str(x.message) for x in w if "averages the cutting force" in str(x.message)]
    assert len(mine) == 1 and "the cuts made in a/D 0.1 down milling, 2 teeth" in mine[0]
    header, cols = res.table()
    assert header[:7] == ["rpm", "depth_mm", "label", "grade", "batch", "radial_immersion", "milling"]
    assert cols[5] == ["", "", "0.1", "0.1", "", "0.1"] and cols[6] == ["", "", "down", "down", "", "down"]
    doc = json.loads(json.dumps(res.to_json(), allow_nan=False))
    assert doc["cuts"]["conditions"] == {"radial_immersion": [None, None, 0.1, 0.1, None, 0.1],
                                         "milling": ["", "", "down", "down", "", "down"]}
    assert doc["cuts"]["extra"] == {"operator": ["ann", "bob", "ann", "bob", "ann", "ann"]}
    assert doc["cuts"]["rpm"] == [5000, 5000, 6000, 6000, 7000, 7000] and doc["cuts"]["grade"][:2] == [0, 1]
    assert res.settings["baseline_features"] == ["rpm", "depth_mm", "entry_deg"]
    with warnings.catch_warnings(record=True) as w:  # an engine of interrupted cutting: nothing to warn of
        warnings.simplefilter("always")
        cross_validate(Cfg(), cuts, n_folds=2, seed=0, samples=150, engine="sdm", update_fn=fake_update)
    assert not [x for x in w if "averages the cutting force" in str(x.message)]


def test_scores_against_their_definitions():
    p = np.array([0.1, 0.8, 0.4, 0.6, 0.3, 0.9])
    g = np.array([0.0, 1.0, 0.5, 0.0, 1.0, 1.0])
    s = scores(p, g)
    assert s["brier"] == pytest.approx(np.mean((p - g) ** 2)) and s["n"] == 6 and s["n_thresholded"] == 5
    m = g != 0.5
    y, q = g[m], p[m]
    assert s["log_loss"] == pytest.approx(-np.mean(y * np.log(q) + (1 - y) * np.log(1 - q)))
    pos, neg = q[y == 1], q[y == 0]
    pairs = (pos[:, None] > neg[None, :]).mean() + 0.5 * (pos[:, None] == neg[None, :]).mean()
    assert s["auc"] == pytest.approx(pairs)
    assert math.isnan(scores(np.array([0.2, 0.3]), np.array([0.0, 0.0]))["auc"])  # one class: no AUC


def test_cross_validate_plumbing_with_a_stand_in_update():
    """The folds' training sets never hold the held-out cuts, each cut is predicted once per scheme with the
    posterior of its own fold, and the pooled scores are those of the predictions."""
    rng = np.random.default_rng(5)
    n = 12
    rpm = np.repeat([5000.0, 6000, 7000, 8000], 3)
    depth = rng.uniform(0.5, 4, n)
    lab = np.where(depth > 2, "chatter", "stable")
    cuts = PointSet(np.r_[rpm, 6500.0], np.r_[depth, 2.0], np.append(lab, ""), batch=["d1"] * 6 + ["d2"] * 6 + [""])
    seen = []

    def fake_update(cfg, train, **kw):
        seen.append((train.rpm.tolist(), train.depth_mm.tolist(), kw["seed"]))
        return prior_post(200, seed=kw["seed"] % 97)

    class Cfg:
        structure, cutting = STRUCT, CUT

    res = cross_validate(Cfg(), cuts, n_folds=3, seed=2, samples=200, update_fn=fake_update)
    assert res.settings["schemes"] == ["random", "speed", "batch"] and len(seen) == 3 + 4 + 2
    for s in ("random", "speed", "batch"):
        f = res.folds[s]
        assert (f >= 0).all() and set(np.unique(f)) == set(range(len(np.unique(f))))
        for m in ("millstab", "majority", "logistic", "knn"):
            p = res.predictions[s][m]
            assert np.isfinite(p).all() and ((0 <= p) & (p <= 1)).all()
            assert res.summary[s][m]["brier"] == pytest.approx(np.mean((p - res.cuts.grade) ** 2))
    # the boundary point is in every training set, a held-out cut in none of its fold's
    k = 0
    for s in ("random", "speed", "batch"):
        for fold in np.unique(res.folds[s]):
            tr_rpm, tr_depth, _ = seen[k]
            k += 1
            assert 2.0 in tr_depth and 6500.0 in tr_rpm
            held = set(res.cuts.depth_mm[res.folds[s] == fold].tolist())
            assert not held & set(tr_depth)
    assert res.table()[0][:5] == ["rpm", "depth_mm", "label", "grade", "batch"]
    with pytest.raises(InputError, match="at least 4"):
        cross_validate(Cfg(), cuts.subset(np.arange(3)), update_fn=fake_update)


@pytest.mark.slow
def test_validate_command_end_to_end(tmp_path, capsys):
    (tmp_path / "cuts.csv").write_text("rpm,depth_mm,label_a,label_b\n5000,1.0,stable,stable\n"
                                       "5000,4.0,chatter,chatter\n7000,2.0,stable,1\n7000,5.0,2,chatter\n"
                                       "9000,1.5,0,stable\n9000,4.5,chatter,2\n")
    args = ["validate", "example:ex1", str(tmp_path / "cuts.csv"), "--folds", "2", "--samples", "100", "--seed", "1",
            "--out", str(tmp_path / "v.json"), "--predictions", str(tmp_path / "v.csv")]
    assert main(args) == 2 and "--labels" in capsys.readouterr().err  # the codes need a mapping
    assert main(args + ["--labels", "0=stable,1=marginal,2=chatter"]) == 0
    out = capsys.readouterr().out
    assert "random folds" in out and "leave one speed out" in out and "logistic" in out
    doc = json.loads((tmp_path / "v.json").read_text())
    assert doc["schema"] == "millstab.validation/1" and set(doc["summary"]) == {"random", "speed"}
    assert len(doc["summary"]["speed"]["millstab"]["fold_brier"]) == 3
    rows = list(csv.DictReader((tmp_path / "v.csv").open()))
    assert len(rows) == 6 and float(rows[2]["grade"]) == 0.25


@pytest.mark.slow
def test_validate_command_on_cuts_in_several_conditions(tmp_path, capsys):
    """validate --out --predictions on a shop's cuts in two conditions (real zero-order updates): the below-one-tooth
    warning of update on stderr, the condition columns in the predictions CSV and in the JSON's cuts, the
    baselines' features named in its settings."""
    (tmp_path / "cuts.csv").write_text("rpm,depth_mm,radial_immersion,milling,label\n5000,1.0,,,stable\n"
                                       "5000,4.0,,,chatter\n7000,2.0,0.1,down,stable\n7000,9.0,0.1,down,chatter\n"
                                       "9000,1.5,,,stable\n9000,6.5,0.1,down,chatter\n")
    assert main(["validate", "example:ex1", str(tmp_path / "cuts.csv"), "--folds", "2", "--samples", "100",
                 "--out", str(tmp_path / "v.json"), "--predictions", str(tmp_path / "v.csv")]) == 0
    cap = capsys.readouterr()
    err, out = " ".join(cap.err.split()), " ".join(cap.out.split())
    assert "averages the cutting force" in err and "the cuts made in a/D 0.1 down milling, 2 teeth" in err
    rows = list(csv.DictReader((tmp_path / "v.csv").open()))
    assert [r["radial_immersion"] for r in rows] == ["", "", "0.1", "0.1", "", "0.1"]
    assert [r["milling"] for r in rows] == ["", "", "down", "down", "", "down"]
    doc = json.loads((tmp_path / "v.json").read_text())
    assert doc["cuts"]["conditions"]["milling"] == ["", "", "down", "down", "", "down"]
    assert doc["settings"]["baseline_features"] == ["rpm", "depth_mm", "entry_deg"]
    # cuts in two conditions: leave one condition out is a scheme of its own, each condition one fold (the slot's
    # three cuts predicted from the a/D 0.1 cuts alone and back); fails on the old code (no such scheme)
    assert doc["settings"]["schemes"] == ["random", "speed", "condition"]
    assert doc["folds"]["condition"] == [0, 0, 1, 1, 0, 1]
    assert "leave one cutting condition out (2 folds, 6 cuts)" in out
    assert [r["condition_fold"] for r in rows] == ["0", "0", "1", "1", "0", "1"]


@pytest.mark.parametrize("argv,shown", [(["predict", "--help"], "p_stable,p_label_chatter"),
                                        (["validate", "--help"], "0=stable,1=marginal,2=chatter")])
def test_help_of_the_new_commands(capsys, argv, shown):
    assert main(argv) == 0
    assert shown in " ".join(capsys.readouterr().out.split())


def test_validate_refuses_bad_options_before_any_update(tmp_path, capsys):
    (tmp_path / "cuts.csv").write_text("rpm,depth_mm,label\n5000,1,stable\n5000,4,chatter\n7000,2,stable\n"
                                       "7000,5,chatter\n")
    base = ["validate", "example:ex1", str(tmp_path / "cuts.csv")]
    assert main(base + ["--folds", "1"]) == 2 and "--folds" in capsys.readouterr().err
    assert main(base + ["--samples", "10"]) == 2 and "--samples" in capsys.readouterr().err
    assert main(base + ["--out", str(tmp_path / "cuts.csv")]) == 2 and "cuts.csv" in capsys.readouterr().err


@pytest.mark.slow
def test_update_reads_coded_labels_of_two_operators(tmp_path):
    (tmp_path / "cuts.csv").write_text("rpm,depth_mm,label_a,label_b,notes\n5000,1.0,0,0,\n5500,4.0,2,2,loud\n"
                                       "7000,3.0,1,2,\n9000,2.5,0,1,\n")
    args = ["update", "example:ex1", str(tmp_path / "cuts.csv"), "--samples", "100", "--out", str(tmp_path / "p.json")]
    assert main(args) == 2
    assert main(args + ["--labels", "0=stable,1=marginal,2=chatter"]) == 0
    cuts = json.loads((tmp_path / "p.json").read_text())["cuts"]
    # grades 0, 1, 0.75, 0.25: the nearest classes
    assert cuts["label"] == ["stable", "chatter", "chatter", "stable"]
