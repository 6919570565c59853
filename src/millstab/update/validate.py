"""Cross-validation of the posterior's predictions on a shop's own cuts: "can I trust it on my machine?".

For each fold the posterior is updated on the training cuts only, and the held-out cuts' chance of a
"chatter" label (:func:`millstab.update.predict.predict_cuts`, with the posterior's label model) is scored
against what was written. Three baselines get the same folds, the same features and the same targets:

* ``majority``: the training cuts' rate of chatter (the mean graded label), a constant;
* ``logistic``: logistic regression on the standardised features (scikit-learn, C = 1); graded labels
  enter as two weighted rows (chatter with weight g, stable with weight 1 − g), the exact
  log-likelihood of a graded target;
* ``knn``: the mean graded label of the k = round(√n_train) nearest training cuts in the standardised
  feature space (scikit-learn's KNeighborsRegressor; √n is the classical consistent choice and needs
  no inner loop).

The baselines' features (:func:`baseline_features`): rpm [rev/min] and depth [mm] and, where the cuts' cutting
conditions differ (a shop's slots and half-width cuts in one file), each cut's own condition as
:data:`CONDITION_FEATURES`: its entry and exit angles [deg] and its number of teeth, each of them only where it
differs between the cuts. The angles are the one description every condition has (a/D and up/down where it is
one: a slot 0-180°, down milling at a/D 0.5 90-180°, up milling 0-90°; general angles too), and they carry
both the engagement (exit − entry, a linear combination) and the side of the cut; each feature is standardised
like rpm and depth (mean 0, sd 1 over the training cuts). Without them a slot and a half-width cut at one speed
and depth look identical to the baselines, which then cannot learn what millstab is given (its conditions),
and millstab's lead over them is flattered. With one condition the features are (rpm, depth), as before.

Fold schemes (each cut is held out exactly once per scheme; boundary points always stay in training):

* ``random``: K folds at random (``KFold(shuffle=True, random_state=seed)``);
* ``speed``: leave one speed out: speeds within 0.5 % of each other are one speed; when there are more
  than ``max_speeds`` of them they are merged into K contiguous speed bands of about equal numbers of
  cuts. It asks whether the model carries to speeds it has not seen — where a shop will use it;
* ``batch``: leave one test day out, when the cuts carry two or more batches (days drift: fn a few %,
  a new tool, another operator);
* ``condition``: leave one cutting condition out, when the cuts were made in two or more (a/D, up or down,
  teeth: :func:`millstab.points.cut_conditions`). It asks what a shop asks before deciding in a condition it has
  not cut: whether cuts in the others carry to it. Random folds and left-out speeds keep every condition in
  training and score a posterior where it was trained (an exploratory shop test: Brier 0.011 in random folds,
  0.188 on the same posterior's cuts in a condition never cut).

Scores, pooled over the held-out predictions of a scheme (per-fold Brier scores kept too):
Brier = mean (p − g)² against the graded label g ∈ [0, 1] (proper for graded targets); log loss and AUC
against the thresholded label y = [g > ½] (cuts with g = ½ exactly, a plain "marginal" or a split vote of
two raters, are left out of these two: they are neither), p clipped to [10⁻⁶, 1 − 10⁻⁶] in the log loss.
Units: rpm, mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from millstab.errors import InputError
from millstab.points import PointSet

METHODS = ("millstab", "majority", "logistic", "knn")
#: relative speed difference within which two cuts are "the same speed" for leave-one-speed-out
SAME_SPEED = 0.005
#: the most speed groups left out one by one (more: merged into K contiguous bands)
MAX_SPEEDS = 10


def speed_groups(rpm: np.ndarray, n_folds: int, max_speeds: int = MAX_SPEEDS) -> np.ndarray:
    """Group index (n,) of each speed: runs of sorted speeds less than :data:`SAME_SPEED` apart are one speed;
    more than ``max_speeds`` speeds are merged into ``n_folds`` contiguous bands of about equal counts."""
    r = np.asarray(rpm, float)
    order = np.argsort(r, kind="stable")
    rs = r[order]
    new = np.r_[True, np.diff(rs) > SAME_SPEED * rs[:-1]]
    g_sorted = np.cumsum(new) - 1
    n_groups = int(g_sorted[-1]) + 1 if r.size else 0
    if n_groups > max_speeds:
        # contiguous bands: cut the sorted cuts into n_folds near-equal parts, at speed-group boundaries
        counts = np.bincount(g_sorted, minlength=n_groups)
        edges = np.cumsum(counts) / r.size  # the share of cuts up to each group's end
        band = np.minimum((np.r_[0.0, edges[:-1]] * n_folds + 1e-9).astype(int), n_folds - 1)
        g_sorted = band[g_sorted]
        g_sorted = np.unique(g_sorted, return_inverse=True)[1]
    out = np.empty(r.size, int)
    out[order] = g_sorted
    return out


def fold_indices(cuts: PointSet, scheme: str, n_folds: int, seed: int,
                 max_speeds: int = MAX_SPEEDS, condition: np.ndarray | None = None) -> list[np.ndarray]:
    """The held-out indices (into the labelled cuts, in file order) of each fold of ``scheme``; ``condition``: each
    cut's condition index (:func:`millstab.points.cut_conditions`), for the ``condition`` scheme."""
    from sklearn.model_selection import KFold

    lab = np.flatnonzero(~cuts.boundary)
    n = lab.size
    if scheme == "random":
        k = min(n_folds, n)
        return [test for _, test in KFold(k, shuffle=True, random_state=seed).split(np.zeros(n))]
    if scheme == "speed":
        groups = speed_groups(cuts.rpm[lab], n_folds, max_speeds)
    elif scheme == "batch":
        groups = np.unique(cuts.batch[lab], return_inverse=True)[1]
    elif scheme == "condition" and condition is not None:
        groups = np.unique(np.asarray(condition)[lab], return_inverse=True)[1]
    else:
        raise InputError("scheme", scheme, "one of random, speed, batch, condition (with each cut's condition)")
    return [np.flatnonzero(groups == g) for g in np.unique(groups)]


#: the baselines' features of a cut's cutting condition (where the cuts' conditions differ): entry and exit angle
#: [deg], number of teeth
CONDITION_FEATURES = ("entry_deg", "exit_deg", "teeth")
#: a condition feature differing by less than this over the cuts is constant (angles [deg] of one condition agree
#: to ~1e-7 deg: :data:`millstab.points.ANGLE_TOL` rad)
CONSTANT = 1e-6


def condition_features(cuts: PointSet, base, diameter_mm: float | None = None) -> np.ndarray:
    """(n, 3) the :data:`CONDITION_FEATURES` of each cut's own condition: entry and exit angle [deg] and teeth (its
    condition columns, empty cells ``base``'s, the config's :class:`~millstab.model.Cutting`:
    :func:`millstab.points.cut_conditions`; ``diameter_mm`` [mm] for a radial_width_mm column)."""
    from millstab.points import cut_conditions

    conds, idx = cut_conditions(cuts, base, diameter_mm)
    return np.array([[math.degrees(c.entry), math.degrees(c.exit), c.teeth] for c in conds], float)[idx]


def baseline_features(cuts: PointSet, base=None, diameter_mm: float | None = None) -> tuple[str, ...]:
    """The names of the baselines' features for these labelled cuts (module docstring): rpm, depth_mm and the
    :data:`CONDITION_FEATURES` that differ between the cuts' conditions (none without ``base``, the config's
    cutting, or with one condition)."""
    return ("rpm", "depth_mm") + (() if base is None else _varying(condition_features(cuts, base, diameter_mm)))


def _varying(f: np.ndarray) -> tuple[str, ...]:
    """The :data:`CONDITION_FEATURES` that differ between the rows of ``f`` (n, 3)."""
    return tuple(n for n, d in zip(CONDITION_FEATURES, np.ptp(f, axis=0) if len(f) else ()) if d > CONSTANT)


def _features(cuts: PointSet, names: tuple[str, ...] = ("rpm", "depth_mm"), base=None,
              diameter_mm: float | None = None) -> np.ndarray:
    """(n, len(names)) the features ``names`` of each cut (rpm [rev/min], depth [mm], condition features)."""
    cols = [cuts.rpm, cuts.depth_mm]
    if len(names) > 2:
        f = condition_features(cuts, base, diameter_mm)
        cols += [f[:, CONDITION_FEATURES.index(n)] for n in names[2:]]
    return np.column_stack(cols)


def baseline_predictions(train: PointSet, test: PointSet, base=None,
                         diameter_mm: float | None = None) -> dict[str, np.ndarray]:
    """P(chatter label) of the test cuts by the three baselines trained on the labelled training cuts; with
    ``base`` (the config's :class:`~millstab.model.Cutting`, filling empty condition cells; ``diameter_mm`` [mm]
    for a radial_width_mm column) they also see each cut's cutting condition where the conditions of the
    training and test cuts differ (:func:`baseline_features`, module docstring)."""
    from sklearn.linear_model import LogisticRegression
    from sklearn.neighbors import KNeighborsRegressor
    from sklearn.preprocessing import StandardScaler

    t = train.subset(~train.boundary)
    g = t.grade
    rate = float(g.mean())
    out = {"majority": np.full(len(test), rate)}
    names = ("rpm", "depth_mm")
    if base is not None:  # the features that differ over the training and test cuts together (every fold: all cuts)
        names += _varying(np.vstack([condition_features(t, base, diameter_mm),
                                     condition_features(test, base, diameter_mm)]))
    x, xt = _features(t, names, base, diameter_mm), _features(test, names, base, diameter_mm)
    sc = StandardScaler().fit(x)
    x, xt = sc.transform(x), sc.transform(xt)
    if 0 < rate < 1 and (g > 0).any() and (g < 1).any():
        # a graded target g is a chatter row of weight g and a stable row of weight 1 − g
        xx = np.vstack([x, x])
        yy = np.r_[np.ones(len(g)), np.zeros(len(g))]
        ww = np.r_[g, 1 - g]
        keep = ww > 0
        lr = LogisticRegression(C=1.0).fit(xx[keep], yy[keep], sample_weight=ww[keep])
        out["logistic"] = lr.predict_proba(xt)[:, 1]
    else:  # one class only: nothing to regress on
        out["logistic"] = np.full(len(test), rate)
    k = max(1, min(len(g), int(round(math.sqrt(len(g))))))
    out["knn"] = np.clip(KNeighborsRegressor(n_neighbors=k).fit(x, g).predict(xt), 0.0, 1.0)
    return out


def scores(p: np.ndarray, grade: np.ndarray) -> dict:
    """Brier (graded target), log loss and AUC (thresholded target, g = ½ left out) of predictions p."""
    from sklearn.metrics import log_loss, roc_auc_score

    p = np.asarray(p, float)
    g = np.asarray(grade, float)
    out = {"n": int(g.size), "brier": float(np.mean((p - g) ** 2)) if g.size else math.nan}
    m = g != 0.5
    y = (g[m] > 0.5).astype(int)
    pc = np.clip(p[m], 1e-6, 1 - 1e-6)
    both = y.size and 0 < y.sum() < y.size
    out["log_loss"] = float(log_loss(y, pc, labels=[0, 1])) if y.size else math.nan
    out["auc"] = float(roc_auc_score(y, pc)) if both else math.nan
    out["n_thresholded"] = int(y.size)
    return out


#: how each fold scheme is named where a person reads it
SCHEME_NAMES = {"random": "random folds", "speed": "leave one speed out", "batch": "leave one day (batch) out",
                "condition": "leave one cutting condition out"}


@dataclass
class Validation:
    """The result of :func:`cross_validate`.

    Attributes:
        cuts: the labelled cuts that were held out (file order).
        predictions: {scheme: {method: (n,) P(chatter label) of each cut when it was held out}}.
        folds: {scheme: (n,) the fold each cut was held out in}.
        summary: {scheme: {method: scores (:func:`scores`) pooled over the folds, plus "fold_brier"}}.
        notes: what went wrong in a fold (an update that could not run), for the user.
        settings: folds, seed, samples, engine, schemes, the baselines' features (``baseline_features``).
    """

    cuts: PointSet
    predictions: dict = field(default_factory=dict)
    folds: dict = field(default_factory=dict)
    summary: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)
    settings: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        """The report as plain JSON (``"schema"``): settings, summary, notes, the held-out cuts with every column
        (:func:`millstab.jsondoc.points_out`: rpm, depth_mm, label, grade, batch, raters, the per-cut condition
        columns, the kept columns), folds and predictions."""
        from millstab.jsondoc import points_out

        return {"schema": "millstab.validation/1", "settings": self.settings, "summary": self.summary,
                "notes": self.notes, "cuts": points_out(self.cuts),
                "folds": {s: f.tolist() for s, f in self.folds.items()},
                "predictions": {s: {m: p.tolist() for m, p in d.items()} for s, d in self.predictions.items()}}

    def score_tables(self) -> list[tuple[str, tuple[str, ...], list[tuple[str, ...]], str]]:
        """What ``millstab validate`` prints, per scheme: (title, header, rows as text, caption); the rows are the
        methods' pooled Brier (the lowest marked *), log loss, AUC and range of the per-fold Brier."""
        out = []
        caption = ("Brier against the graded label (lower is better); log loss and AUC against chatter (grade > 1/2), "
                   "marginal cuts left out")
        for s, rows in self.summary.items():
            best = min(r["brier"] for r in rows.values())
            text = [(m, f"{r['brier']:.4f}" + (" *" if r["brier"] <= best else ""), f"{r['log_loss']:.3f}",
                     f"{r['auc']:.3f}", f"{min(r['fold_brier']):.3f}-{max(r['fold_brier']):.3f}")
                    for m, r in rows.items()]
            ref = rows["millstab"]
            title = f"{SCHEME_NAMES.get(s, s)} ({len(ref['fold_brier'])} folds, {ref['n']} cuts)"
            out.append((title, ("method", "Brier", "log loss", "AUC", "Brier per fold (min-max)"), text, caption))
        return out

    def table(self) -> tuple[list[str], list]:
        """(header, columns) of the per-cut CSV: rpm, depth_mm, label, grade, batch, the cuts' condition columns as
        read (radial_immersion, milling, ...: :func:`millstab.io.points.condition_columns`; empty = the config's),
        then per scheme its fold and each method's held-out P(chatter label)."""
        from millstab.io.points import condition_columns

        c = self.cuts
        h, conds = condition_columns(c)
        header, cols = (["rpm", "depth_mm", "label", "grade", "batch", *h],
                        [c.rpm, c.depth_mm, list(c.label), c.grade, list(c.batch), *conds])
        for s, d in self.predictions.items():
            header.append(f"{s}_fold")
            cols.append(self.folds[s])
            for m, p in d.items():
                header.append(f"{s}_{m}")
                cols.append(p)
        return header, cols


def cross_validate(config, cuts: PointSet, *, n_folds: int = 5, seed: int = 0, samples: int = 1000,
                   engine: str = "zoa", schemes: tuple[str, ...] | None = None, max_speeds: int = MAX_SPEEDS,
                   prior=None, update_fn: Callable | None = None,
                   progress: Callable[[str, int, int], None] | None = None,
                   engine_options: dict | None = None, stickout: np.ndarray | None = None) -> Validation:
    """Cross-validated scores of millstab's predictions beside the baselines (module docstring).

    Args:
        config: the config whose structure is the prior (a modal one: see :func:`millstab.api.modal`).
        cuts: the labelled cuts (boundary points among them stay in every training set).
        n_folds: K of the random folds (and of the speed bands).
        seed: seed of the folds and of every update.
        samples: posterior samples per update.
        engine: the engine of the updates.
        schemes: fold schemes; default random and speed, batch when the cuts carry two or more batches, and
            condition when they were made in two or more cutting conditions.
        prior: a :class:`millstab.update.Prior` instead of the config's (other cutting conditions, noise).
        update_fn: ``update(config, train_cuts, engine=, samples=, seed=)`` → posterior; default
            :func:`millstab.update.update` with ``prior``.
        progress: ``progress(stage, done, total)`` after each update.
        engine_options: the engine's discretisation of every update (passed to ``update_fn`` as
            ``engine_options=`` when given) and so of every prediction (:func:`millstab.forward.engine_options`).
        stickout: each row's tool stickout [m] (NaN: the config's; None: every row there), for a config over the
            holder: each fold's update and each prediction take their cuts' own (:mod:`millstab.update.stickout`).
    Raises:
        InputError: fewer than 4 labelled cuts, folds < 2, an unknown scheme, ``condition`` with the cuts in one
            condition, engine options the engine does not take (before any update).
    """
    from millstab.update import update as run_update, warn_speeds_in_hz, warn_time_averaged_cuts
    from millstab.update.posterior import Posterior
    from millstab.points import cut_conditions
    from millstab.update.predict import predict_at_stickouts
    from millstab.warnlog import quiet

    from millstab.forward import engine_options as check_options

    opts = dict(check_options(engine, engine_options))
    with_opts = {"engine_options": opts} if opts else {}  # an update_fn of the old signature still serves without
    labelled = ~cuts.boundary
    n = int(labelled.sum())
    if n < 4:
        raise InputError("cuts", f"{n} labelled cuts", "cross-validation needs at least 4 labelled cuts")
    if not (isinstance(n_folds, (int, np.integer)) and n_folds >= 2):
        raise InputError("--folds", n_folds, "need an integer ≥ 2")
    lab = cuts.subset(labelled)
    bnd = cuts.subset(cuts.boundary)
    so = None if stickout is None or np.isnan(stickout).all() else np.asarray(stickout, dtype=float)
    so_lab, so_bnd = (None, None) if so is None else (so[labelled], so[cuts.boundary])
    if so is not None and prior is None and update_fn is None:  # refused before the folds, not in each of them
        from millstab.update.stickout import config_prior

        if getattr(config_prior(config).par, "at", None) is None:
            from millstab.update.stickout import not_over_holder

            raise not_over_holder(so)
    base = prior.cutting if prior is not None else config.cutting  # what an empty condition cell means
    diameter = getattr(config, "diameter_mm", None)
    warn_time_averaged_cuts(engine, cut_conditions(cuts, base, diameter)[0])  # as update (the folds' are quiet)
    warn_speeds_in_hz(config, cuts)
    lab_cond = cut_conditions(lab, base, diameter)[1]  # each labelled cut's condition
    n_cond = np.unique(lab_cond).size
    if schemes is None:
        schemes = ("random", "speed") + (("batch",) if np.unique(lab.batch[lab.batch != ""]).size >= 2 else ()) + (
            ("condition",) if n_cond >= 2 else ())
    if "condition" in schemes and n_cond < 2:
        raise InputError("scheme", "condition", "leaving one cutting condition out needs cuts in two or more")
    update_fn = update_fn or (lambda cfg, tr, **kw: run_update(cfg, tr, prior=prior, **kw))
    plan = [(s, i, test) for s in schemes
            for i, test in enumerate(fold_indices(lab, s, n_folds, seed, max_speeds, lab_cond))]
    out = Validation(lab, settings={"folds": int(n_folds), "seed": int(seed), "samples": int(samples), "engine": engine,
                                    "schemes": list(schemes), **with_opts,
                                    "baseline_features": list(baseline_features(lab, base, diameter))})
    for s in schemes:
        out.predictions[s] = {m: np.full(n, np.nan) for m in METHODS}
        out.folds[s] = np.full(n, -1)
    for done, (s, i, test) in enumerate(plan):
        mask = np.zeros(n, bool)
        mask[test] = True
        tr = lab.subset(~mask)
        train = tr if not len(bnd) else _concat(tr, bnd)
        te = lab.subset(mask)
        at = {} if so is None else {"stickout": np.r_[so_lab[~mask], so_bnd]}  # the training rows' own
        try:
            with quiet():  # one-sided folds and speeds beyond the training cuts are expected here
                post = update_fn(config, train, engine=engine, samples=samples, seed=int(seed) * 1000 + done,
                                 **with_opts, **at)
        except (InputError, RuntimeError) as exc:  # a fold the model cannot be updated on: the prior predicts
            from millstab.update.stickout import config_prior

            out.notes.append(f"{s} fold {i}: update failed ({exc}); the prior predicted it")
            pr = prior or config_prior(config)  # the update's own prior (over a holder for a [tool] config)
            post = Posterior(pr, np.exp(pr.sample(samples, np.random.default_rng(seed))), engine, engine_options=opts)
        conds, ci = cut_conditions(te, post.condition, diameter)  # each cut's own
        out.predictions[s]["millstab"][mask] = predict_at_stickouts(post, te.rpm, te.depth_mm, conds, ci, te.batch,
                                                                    None if so is None else so_lab[mask])[1]
        for m, p in baseline_predictions(tr, te, base, diameter).items():
            out.predictions[s][m][mask] = p
        out.folds[s][mask] = i
        if progress is not None:
            progress(f"{s} fold {i}", done + 1, len(plan))
    for s in schemes:
        out.summary[s] = {}
        for m in METHODS:
            sc = scores(out.predictions[s][m], lab.grade)
            sc["fold_brier"] = [float(np.mean((out.predictions[s][m][out.folds[s] == f]
                                               - lab.grade[out.folds[s] == f]) ** 2))
                                for f in np.unique(out.folds[s])]
            out.summary[s][m] = sc
    return out


def _concat(a: PointSet, b: PointSet) -> PointSet:
    """Training cuts and the boundary points (the raters of ``a``; a boundary point has no rating)."""
    r = np.vstack([a.ratings, np.full((len(b), a.ratings.shape[1]), np.nan)])
    # the condition columns of both (a column one of them lacks: empty cells there, the config's condition)
    cond = {k: np.r_[a.conditions.get(k, _empty(a, k)), b.conditions.get(k, _empty(b, k))]
            for k in {*a.conditions, *b.conditions}}
    return PointSet(np.r_[a.rpm, b.rpm], np.r_[a.depth_mm, b.depth_mm], np.r_[a.label, b.label],
                    np.r_[a.weight, b.weight], a.source, np.r_[a.chatter_hz, b.chatter_hz], np.r_[a.grade, b.grade],
                    np.r_[a.batch, b.batch], r, a.raters, conditions=cond)


def _empty(p: PointSet, column: str) -> np.ndarray:
    """An all-empty condition column for ``p`` (``""`` for milling, NaN otherwise)."""
    return np.full(len(p), "", dtype=object) if column == "milling" else np.full(len(p), np.nan)


__all__ = ["METHODS", "MAX_SPEEDS", "SAME_SPEED", "Validation", "baseline_predictions", "cross_validate",
           "fold_indices", "scores", "speed_groups"]
