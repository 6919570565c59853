"""Cross-validation of millstab's predictions on a shop's own cuts beside simple baselines
(``millstab validate``; the study is :mod:`millstab.update.validate`)."""

from __future__ import annotations

from millstab.api.inputs import config, modal
from millstab.api.inputs import points as point_set
from millstab.progress import Progress
from millstab.errors import InputError
from millstab.points import PointSet


def validate(cfg, cuts: PointSet, *, folds: int = 5, seed: int = 0, samples: int = 1000, engine: str = "zoa",
             progress: Progress | None = None, engine_options: dict | None = None):
    """Cross-validated Brier score, log loss and AUC of millstab's P(chatter label) and of the majority rate,
    logistic regression and k-nearest-neighbours, by random folds, leave-one-speed-out, (with two or more batches)
    leave-one-day-out and (with cuts in two or more conditions) leave-one-condition-out
    (:func:`millstab.update.validate.cross_validate`); a measured-FRF config's
    prior centres on its fitted modes; ``engine_options``: the engine's discretisation of every fold's update
    and prediction (as :func:`millstab.api.update`).

    Raises:
        InputError: fewer than 100 samples, fewer than 4 labelled cuts, folds < 2, an unknown engine, engine
            options it does not take (``--engine-option``).
    """
    from millstab.stability import check_engine_name
    from millstab.update.validate import cross_validate

    from millstab.bounds import check_cuts
    from millstab.bounds import samples as check_samples

    check_samples(samples)  # a whole number 100..10^6, as update's (a text "200" was numpy's TypeError)
    cfg = config(cfg)  # a Config, a file, "example:NAME" or its tables
    cuts = point_set(cuts, "cuts")  # a PointSet, a file, or a notebook's table
    check_cuts(len(cuts))
    check_engine_name(engine)
    from millstab.api.update import check_engine_options

    from millstab.api.update import over_holder
    from millstab.io.stickout import stickouts

    engine_options = check_engine_options(engine, engine_options)  # before any fold's update
    if not over_holder(cfg):  # as update: a prior over the holder needs no tip modes
        cfg, _ = modal(cfg)
    # each cut at its own stickout (a stickout_mm column; over the holder): the folds' updates and predictions too
    return cross_validate(cfg, cuts, n_folds=folds, seed=seed, samples=samples, engine=engine, progress=progress,
                          engine_options=engine_options, stickout=stickouts(cuts))


__all__ = ["validate"]
