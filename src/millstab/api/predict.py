"""Honest predictions for given cuts from a posterior (``millstab predict``): per cut the chance that the
process is stable and the chance that an operator writes "chatter" (the posterior's label model), in the
input order; with labelled cuts, their scores against the written labels."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from millstab.points import PointSet

#: the ``"schema"`` of :meth:`Prediction.to_json`
SCHEMA = "millstab.prediction/1"


@dataclass(frozen=True)
class Prediction:
    """Predictions for n cuts (rpm, mm), in the order of the cuts file.

    Attributes:
        cuts: the cuts as read (labels, grades, batches).
        p_stable: (n,) probability that the cut is stable (the fraction of posterior samples whose limit
            lies above its depth: the process, free of how labels are written).
        p_label_chatter: (n,) probability that the written label says chatter (with the posterior's label
            model: :func:`millstab.update.predict.predict_cuts`).
        warnings: the posterior's own warnings (a prior-data conflict among them), then the prediction's.
        condition: (n,) str, the cutting condition each prediction is computed for ("a/D 0.25 up milling,
            4 teeth"): the cut's own condition columns, else the posterior's (target) condition; ``None``
            when every cut is in the one condition the posterior was trained in (the table has no column).
        provenance: what it was made from, ``{"config": the posterior's config name, "points": the cuts file}``
            (each where known; top-level keys of its JSON).
        note: (n,) str, :func:`millstab.points.never_cut_note` on each cut whose condition none of the posterior's
            cuts was made in (the words of ``map`` and ``recommend``: there the prediction leans on the model's
            carrying over from other conditions), ``""`` on the others; ``None`` when every cut's condition was cut.
        stickout_mm: (n,) the tool stickout [mm] each prediction is for (the cut's ``stickout_mm`` cell, else the
            posterior's: ``--stickout`` or the config's); ``None`` for a posterior over the tip's modes.
    """

    SCHEMA = SCHEMA

    cuts: PointSet
    p_stable: np.ndarray
    p_label_chatter: np.ndarray
    warnings: tuple[str, ...] = ()
    condition: np.ndarray | None = None
    provenance: dict = field(default_factory=dict)
    note: np.ndarray | None = None
    stickout_mm: np.ndarray | None = None

    def to_json(self) -> dict:
        """The predictions as plain JSON (``"schema"``): the cuts (:func:`millstab.jsondoc.points_out`),
        ``p_stable`` and ``p_label_chatter`` per cut, the posterior's warnings, the condition per cut (or null), the
        never-cut note per cut (``note``, or null) and the provenance."""
        from millstab.jsondoc import floats_out, points_out

        return {"schema": SCHEMA, "cuts": points_out(self.cuts), "p_stable": floats_out(self.p_stable, "p_stable"),
                "p_label_chatter": floats_out(self.p_label_chatter, "p_label_chatter"), "warnings": list(self.warnings),
                "condition": None if self.condition is None else [str(c) for c in self.condition],
                "note": None if self.note is None else [str(c) for c in self.note],
                "stickout_mm": None if self.stickout_mm is None else floats_out(self.stickout_mm, "stickout_mm"),
                **{k: str(v) for k, v in self.provenance.items()}}

    @classmethod
    def from_json(cls, doc: dict, source: str = "prediction") -> Prediction:
        """Rebuild predictions from :meth:`to_json` output.

        Raises:
            InputError: another schema, or a missing or malformed field (named ``source: field``).
        """
        from millstab.jsondoc import check_schema, floats_in, names_in, need, points_in

        check_schema(doc, SCHEMA, source)
        cond, note = doc.get("condition"), doc.get("note")  # a document of before the note: none
        return cls(points_in(need(doc, "cuts", source, dict), f"{source}: cuts"),
                   floats_in(need(doc, "p_stable", source), f"{source}: p_stable", 1),
                   floats_in(need(doc, "p_label_chatter", source), f"{source}: p_label_chatter", 1),
                   names_in(need(doc, "warnings", source), f"{source}: warnings"),
                   None if cond is None else np.array(names_in(cond, f"{source}: condition"), dtype=object),
                   {k: need(doc, k, source, str) for k in ("config", "points") if k in doc},
                   None if note is None else np.array(names_in(note, f"{source}: note"), dtype=object),
                   None if doc.get("stickout_mm") is None  # a document of before the stickout: none
                   else floats_in(doc["stickout_mm"], f"{source}: stickout_mm", 1))

    def table(self) -> tuple[list[str], list]:
        """(header, columns) of the CSV: every column of the cuts file in its order, as read
        (:func:`millstab.io.points.input_columns`: labels, raters, chatter_hz, condition columns, notes, ...; cuts
        not read from a file: rpm, depth_mm, label where any cut is labelled), then p_stable and p_label_chatter
        (both exact: p_stable is a fraction of the N posterior samples, a multiple of 1/N, so it shows 3 decimals
        with 1000 samples; neither is rounded, as every CSV of millstab), condition (where the cuts' conditions
        differ from the posterior's one) and condition_note (where a cut's condition was never cut: :attr:`note`).
        An input column named as one of these (a prediction predicted again) is kept as ``input_NAME``."""
        from millstab.io.points import input_columns

        header, cols = input_columns(self.cuts)
        new = {"p_stable": self.p_stable, "p_label_chatter": self.p_label_chatter}
        if self.condition is not None:
            new["condition"] = list(self.condition)
        if self.note is not None:
            new["condition_note"] = list(self.note)
        if self.stickout_mm is not None:  # the stickout each prediction is for: --stickout or the cut's own
            new["at_stickout_mm"] = self.stickout_mm
        for i, h in enumerate(header):
            while header[i] in new or header.count(header[i]) > 1:
                header[i] = f"input_{header[i]}"
        return header + list(new), cols + list(new.values())

    def figure(self, ax=None, *, title: str = ""):
        """The cuts coloured by P(stable), the labelled ones ringed by their written label
        (:func:`millstab.plot.update.plot_prediction`), into ``ax`` or a new figure, which it returns."""
        from millstab.plot.update import plot_prediction

        c = self.cuts
        labels = np.where(c.boundary, "", c.label.astype(str)) if (~c.boundary).any() else None
        return plot_prediction(c.rpm, c.depth_mm, self.p_stable, labels, title=title, ax=ax)

    def summary(self) -> str:
        """What ``millstab predict`` prints after the condition: the range of P(stable) and, with labelled cuts,
        their Brier score beside that of their own chatter rate as a constant."""
        n = len(self.cuts)
        lines = [f"{n} cuts: P(stable) {self.p_stable.min():.3f}-{self.p_stable.max():.3f}" if n else "no cuts"]
        if self.note is not None:  # per condition never cut: its cuts, in the words of map and recommend
            never = self.note != ""
            for cond in dict.fromkeys(self.condition[never]):
                m = never & (self.condition == cond)
                lines.append(f"  {m.sum()} of {n} cuts in {cond} ({self.note[m][0]})")
        s = self.scores()
        if s is not None:
            lines.append(f"  against the {s['n']} labelled cuts: Brier score {s['brier']:.4f} (their own chatter rate "
                         f"as a constant: {s['brier_rate']:.4f}); in-sample if these cuts trained the posterior "
                         "(millstab validate gives held-out scores)")
        return "\n".join(lines)

    def scores(self) -> dict | None:
        """Scores of ``p_label_chatter`` against the labelled cuts (``None`` without any): ``n``, ``brier``
        (mean squared difference to the graded label, 0 stable … 1 chatter) and ``brier_rate`` (that of the
        constant rate of chatter labels among these cuts, a baseline that has seen the answers)."""
        m = ~self.cuts.boundary
        if not m.any():
            return None
        g = self.cuts.grade[m]
        p = self.p_label_chatter[m]
        return {"n": int(m.sum()), "brier": float(np.mean((p - g) ** 2)),
                "brier_rate": float(np.mean((g.mean() - g) ** 2))}


def predict(post, cuts: PointSet) -> Prediction:
    """Predictions for the cuts (labelled or not) from a posterior (:class:`millstab.update.Posterior`),
    each in its own cutting condition: the cuts' condition columns (:data:`millstab.points.CONDITION_COLUMNS`),
    empty cells and missing columns taking ``post.condition`` (the config's, or the target of
    :func:`millstab.api.update.for_condition`), and at its own stickout (a ``stickout_mm`` column, with a posterior
    over the holder; an empty cell: the posterior's stickout); a cut in a condition none of the posterior's cuts
    was made in carries the note of map and recommend (:attr:`Prediction.note`). Every warning it issues is kept in
    :attr:`Prediction.warnings` after the posterior's own (its JSON said none while the terminal showed some).

    Raises:
        InputError: bad speeds or depths (see :func:`millstab.update.predict.predict_cuts`), a ``stickout_mm``
            column with a posterior over the tip's modes.
    Warns:
        UserWarning: cuts beyond the tested speeds (there the prediction leans on the prior); a zero-order
            posterior's cuts in a condition with less than one tooth in the cut (:func:`warn_time_averaged`).
    """
    from millstab.update.decide import keeps_warnings

    return keeps_warnings(_predict)(post, cuts)


def _predict(post, cuts: PointSet) -> Prediction:
    """The work of :func:`predict` (which keeps its warnings)."""
    from millstab.bounds import check_cuts
    from millstab.io.stickout import stickouts
    from millstab.update.decide import warn_outside, warn_time_averaged
    from millstab.update.predict import predict_at_stickouts
    from millstab.api.inputs import points as point_set

    cuts = point_set(cuts, "cuts")  # a PointSet, a file, or a notebook's table (DataFrame, list of rows)
    check_cuts(len(cuts))
    if len(cuts):
        warn_outside(post, float(cuts.rpm.min()), float(cuts.rpm.max()), stacklevel=3)
    from millstab.points import condition_text, cut_conditions, never_cut_note, same_condition

    conds, idx = cut_conditions(cuts, post.condition, post.diameter_mm)
    for k in np.unique(idx):  # each condition the cuts are in, once
        warn_time_averaged(post.for_condition(conds[int(k)]), stacklevel=3, rpm=cuts.rpm[idx == k])
    # each cut at its own stickout (a stickout_mm column, a posterior over the holder) and test day (a known day)
    so = stickouts(cuts)
    at = _stickouts_at(post, cuts, so)
    ps, pl = predict_at_stickouts(post, cuts.rpm, cuts.depth_mm, conds, idx, cuts.batch, so)
    text = np.array([condition_text(c) for c in conds], dtype=object)[idx] if len(cuts) else np.array([], dtype=object)
    trained = post.trained_conditions
    one = len(trained) == 1 and same_condition(trained[0], post.condition)
    if one and not cuts.has_conditions:  # the posterior's one condition throughout: the table as ever
        text = None
    cut = np.array([any(same_condition(t, c) for t in trained) for c in conds], dtype=bool)[idx]
    note = None if cut.all() else np.where(cut, "", never_cut_note(trained)).astype(object)
    made = {"config": post.provenance.get("config"), "points": None if cuts.source is None else str(cuts.source)}
    return Prediction(cuts, np.asarray(ps, float), np.asarray(pl, float), tuple(post.warnings), text,
                      {k: v for k, v in made.items() if v is not None}, note, at)


def _stickouts_at(post, cuts: PointSet, so) -> np.ndarray | None:
    """Each cut's stickout [mm] its prediction is for (its ``stickout_mm`` cell, else the posterior's), checked against
    the tool (:func:`millstab.update.stickout.check_stickout_mm`: 0.055 or a stickout under the fluted length was
    predicted P(stable) = 1 silently) and warned beyond the stickouts of the posterior's cuts; ``None`` for a
    posterior over the tip's modes (no stickout; a ``stickout_mm`` column is then refused by the prediction)."""
    from millstab.update.stickout import check_stickouts_mm, stickout_mm_of, warn_outside_stickouts

    own = stickout_mm_of(post)
    if own is None:
        return None
    mm = np.full(len(cuts), own) if so is None else np.where(np.isnan(so), own, so * 1e3)
    if so is not None:
        where = getattr(cuts.source, "name", "cuts")
        check_stickouts_mm(so * 1e3, f"{where} row {{row}}, stickout_mm", getattr(post.prior.par, "tool", None))
        for v in {float(mm.min()), float(mm.max())} - {own}:  # --stickout itself was warned where it was given
            warn_outside_stickouts(post, v, stacklevel=4)
    return mm


__all__ = ["SCHEMA", "Prediction", "predict"]
