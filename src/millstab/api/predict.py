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
        warnings: the posterior's own warnings (a prior-data conflict among them).
        condition: (n,) str, the cutting condition each prediction is computed for ("a/D 0.25 up milling,
            4 teeth"): the cut's own condition columns, else the posterior's (target) condition; ``None``
            when every cut is in the one condition the posterior was trained in (the table has no column).
        provenance: what it was made from, ``{"config": the posterior's config name, "points": the cuts file}``
            (each where known; top-level keys of its JSON).
    """

    SCHEMA = SCHEMA

    cuts: PointSet
    p_stable: np.ndarray
    p_label_chatter: np.ndarray
    warnings: tuple[str, ...] = ()
    condition: np.ndarray | None = None
    provenance: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        """The predictions as plain JSON (``"schema"``): the cuts (:func:`millstab.jsondoc.points_out`),
        ``p_stable`` and ``p_label_chatter`` per cut, the posterior's warnings, the condition per cut (or null) and
        the provenance."""
        from millstab.jsondoc import floats_out, points_out

        return {"schema": SCHEMA, "cuts": points_out(self.cuts), "p_stable": floats_out(self.p_stable, "p_stable"),
                "p_label_chatter": floats_out(self.p_label_chatter, "p_label_chatter"), "warnings": list(self.warnings),
                "condition": None if self.condition is None else [str(c) for c in self.condition],
                **{k: str(v) for k, v in self.provenance.items()}}

    @classmethod
    def from_json(cls, doc: dict, source: str = "prediction") -> Prediction:
        """Rebuild predictions from :meth:`to_json` output.

        Raises:
            InputError: another schema, or a missing or malformed field (named ``source: field``).
        """
        from millstab.jsondoc import check_schema, floats_in, names_in, need, points_in

        check_schema(doc, SCHEMA, source)
        cond = doc.get("condition")
        return cls(points_in(need(doc, "cuts", source, dict), f"{source}: cuts"),
                   floats_in(need(doc, "p_stable", source), f"{source}: p_stable", 1),
                   floats_in(need(doc, "p_label_chatter", source), f"{source}: p_label_chatter", 1),
                   names_in(need(doc, "warnings", source), f"{source}: warnings"),
                   None if cond is None else np.array(names_in(cond, f"{source}: condition"), dtype=object),
                   {k: need(doc, k, source, str) for k in ("config", "points") if k in doc})

    def table(self) -> tuple[list[str], list]:
        """(header, columns) of the CSV: rpm, depth_mm, label (when any cut is labelled; the written class,
        empty for a boundary point), p_stable, p_label_chatter."""
        c = self.cuts
        labelled = bool((~c.boundary).any())
        header = ["rpm", "depth_mm"] + (["label"] if labelled else []) + ["p_stable", "p_label_chatter"]
        cols = [c.rpm, c.depth_mm] + ([list(c.label)] if labelled else []) + [self.p_stable, self.p_label_chatter]
        if self.condition is not None:
            header.append("condition")
            cols.append(list(self.condition))
        return header, cols

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
        s = self.scores()
        if s is not None:
            lines.append(f"  against the {s['n']} labelled cuts: Brier score {s['brier']:.4f} (their own chatter rate "
                         f"as a constant: {s['brier_rate']:.4f}); for held-out scores use millstab validate")
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
    :func:`millstab.api.update.for_condition`).

    Raises:
        InputError: bad speeds or depths (see :func:`millstab.update.predict.predict_cuts`).
    Warns:
        UserWarning: cuts beyond the tested speeds (there the prediction leans on the prior); a zero-order
            posterior's cuts in a condition with less than one tooth in the cut (:func:`warn_time_averaged`).
    """
    from millstab.update.decide import warn_outside, warn_time_averaged
    from millstab.update.predict import predict_cuts

    if len(cuts):
        warn_outside(post, float(cuts.rpm.min()), float(cuts.rpm.max()), stacklevel=3)
    from millstab.points import condition_text, cut_conditions, same_condition

    conds, idx = cut_conditions(cuts, post.condition, post.diameter_mm)
    for k in np.unique(idx):  # each condition the cuts are in, once
        warn_time_averaged(post.for_condition(conds[int(k)]), stacklevel=3)
    ps, pl = predict_cuts(post, cuts.rpm, cuts.depth_mm, conds, idx, batch=cuts.batch)  # a known day: its shift
    text = np.array([condition_text(c) for c in conds], dtype=object)[idx] if len(cuts) else np.array([], dtype=object)
    one = len(post.trained_conditions) == 1 and same_condition(post.trained_conditions[0], post.condition)
    if one and not cuts.has_conditions:  # the posterior's one condition throughout: the table as ever
        text = None
    made = {"config": post.provenance.get("config"), "points": None if cuts.source is None else str(cuts.source)}
    return Prediction(cuts, np.asarray(ps, float), np.asarray(pl, float), tuple(post.warnings), text,
                      {k: v for k, v in made.items() if v is not None})


__all__ = ["SCHEMA", "Prediction", "predict"]
