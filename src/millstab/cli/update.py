"""``millstab update`` and ``map``: Bayesian updating from test cuts and P(stable) maps (``recommend``:
:mod:`millstab.cli.recommend`)."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from millstab.api import ENGINES
from millstab.cli.app import app
from millstab.cli.history import CampaignOpt, ShopDbOpt, ShopOpt, UserOpt, posterior_source, shop_target
from millstab.cli.options import (DaskOpt, EngineOptionOpt, EntryDegOpt, ExitDegOpt, MillingOpt, RadialImmersionOpt,
                                  RadialWidthOpt, StickoutOpt, TeethOpt, WorkersOpt, engine_option_pairs, for_decision,
                                  samples_option, seed_option)
from millstab.cli.options import dask_client as _client
from millstab.errors import InputError

#: the --labels option of every command that reads a cuts file
LABELS_HELP = ("Codes of the label cells, e.g. 0=stable,1=marginal,2=chatter or yes=chatter,no=stable "
               "(words stable|marginal|chatter and probabilities in [0, 1] need none).")


def _load_posterior(path: Path):
    from millstab import api
    from millstab.io import read_json

    return api.posterior_from_json(read_json(path), str(path))


@app.command("update")
def update_cmd(
    config: str = typer.Argument(...,
                                 help="TOML config: cutting conditions, hammer-test modes (the prior), optional "
                                      "[prior]."),
    cuts: Optional[Path] = typer.Argument(None, help="Cuts CSV rpm,depth_mm,label[,chatter_hz]; label stable|chatter|"
                                                     "marginal, a probability of chatter, or a code (--labels); "
                                                     "label_NAME per rater. Optional with --db/--campaign: the cuts "
                                                     "recorded there since its posterior (e.g. heard by listen)."),
    points: Optional[Path] = typer.Option(None, "--points", help="Boundary points CSV to use as well."),
    engine: str = typer.Option("zoa", "--engine", help=f"Stability engine: {', '.join(ENGINES)} (zoa: fast; zoa and "
                                                       "spectral use measured chatter frequencies)."),
    samples: int = samples_option(4000, "Posterior samples (SMC particles)."),
    seed: int = seed_option(0, "Seed of the sampler (same seed, same samples)."),
    out: Optional[Path] = typer.Option(None, "--out", help="Posterior JSON (schema millstab.posterior/3); optional "
                                                          "with --db."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Pair plot of the posterior (.png/.svg/.pdf)."),
    start: Optional[Path] = typer.Option(None, "--start", help="Posterior JSON of the first cuts of CUTS (from an "
                                         "earlier update): only the later cuts are tempered in (faster)."),
    labels: Optional[str] = typer.Option(None, "--labels", help=LABELS_HELP),
    sampler: str = typer.Option("auto", "--sampler", help="MH moves: auto | delayed | plain | surrogate. delayed: the "
                                "zero-order engine screens each proposal, the chosen engine decides on the survivors "
                                "(same posterior, a third of the engine calls); surrogate: sampled on corrected "
                                "zero-order limits, then the chosen engine once per final sample and importance "
                                "weights (same posterior); auto: delayed for every engine but zoa."),
    batch_effect: Optional[str] = typer.Option(None, "--batch-effect", help="σ of a test day's shift of every natural "
                                               "frequency, e.g. 3% (the cuts' batch/date column; overrides [prior] "
                                               "batch_effect; 0: off, the default)."),
    dask: DaskOpt = None,
    workers: WorkersOpt = None,
    db: ShopDbOpt = None,
    campaign: CampaignOpt = None,
    user: UserOpt = None,
    shop: ShopOpt = None,
    options: EngineOptionOpt = None,
) -> None:
    """Update the modal parameters from labelled test CUTS (Bayesian; tempered SMC); with --db/--campaign the cuts
    and the posterior are recorded in a shop database, starting from the campaign's current posterior."""
    from rich.console import Console

    from millstab import api
    from millstab.cli import emit
    from millstab.io import config_inputs, read_points

    in_db, shop = _target(out, db, campaign, start, shop, cuts)
    cfg = api.with_batch_effect(api.config(config), batch_effect)
    # a 'recording' column: labelled by ear (docs/listen.md); no file with --db: the campaign's cuts not yet updated
    c, heard = api.read_cuts(cuts, labels, cfg.cutting.teeth, cfg.structure) if cuts is not None else (None, [])
    p = read_points(points, labels) if points is not None else None
    protect = emit.checked({**config_inputs(cfg), "CUTS": cuts, "--points": points, "--start": start},
                           {"--out": out, "--plot": plot}, figures=("--plot",))
    cfg, note = (cfg, None) if api.over_holder(cfg) else api.modal(cfg)  # a measured FRF: its fitted modes (issue 14)
    for line in heard + ([note] if note else []):
        typer.echo(line)
    # with --dask/--workers the likelihood's engine calls go to the cluster where that pays (sdm, spectral; not zoa)
    with _client(dask, workers) as client:
        post, done = _run_update(cfg, c, p, client, cuts, db=db, campaign=campaign, user=user, shop=shop, start=start,
                                 engine=engine, samples=samples, seed=seed, sampler=sampler, engine_options=options)
    emit.json(out, post.to_json(), protect, lambda _: None)  # its config's name included: the web download is the same
    con = Console()
    rows = [(row[0], *(f"{v:.{5 if i < len(post.names) else 3}g}" for v in row[1:6]), row[6])
            for i, row in enumerate(zip(*post.table()[1]))]  # parameters (5 digits), then learned noise levels (3)
    emit.table(con, f"{cfg.name}: posterior ({len(post.samples)} samples, {engine})",
               ("parameter", "prior", "mean", "sd", "5 %", "95 %", "unit"), rows, post.summary())
    emit.warnings(con, post.to_json()["warnings"])
    con.print(f"recorded in {db}, campaign {campaign} ({done.cuts} cuts)" if in_db and out is None else f"wrote {out}")
    emit.figure(plot, lambda: api.corner_figure(post), protect, con.print)


def _target(out: Path | None, db, campaign, start: Path | None, shop: str | None,
            cuts: Path | None = None) -> tuple[bool, str | None]:
    """(whether the posterior goes to a shop database (--db/--campaign), the checked --shop of a new campaign);
    InputError for neither target, no CUTS file without a database (with one, the campaign's recorded cuts are
    updated: those `listen --db` heard), --start beside a database (whose campaign's current posterior is the
    start), or --shop without one."""
    in_db = shop_target(db, campaign)
    if cuts is None and not in_db:
        raise InputError("CUTS", None, "missing: the cuts CSV to update from (or --db shop.db --campaign NAME, whose "
                                       "recorded cuts, e.g. heard by listen, are updated)")
    if out is None and not in_db:
        raise InputError("--out", None, "missing: the posterior JSON to write (or --db shop.db --campaign NAME)")
    if in_db and start is not None:
        raise InputError("--start", str(start), "with --db the campaign's current posterior is the start")
    if shop is not None:
        if not in_db:
            raise InputError("--shop", shop, "the shop of a campaign in a shop database: give --db and --campaign too")
        from millstab.api.shop import check_shop

        shop = check_shop(shop)
    return in_db, shop


def _run_update(cfg, cuts, points, client, source=None, *, db, campaign, user, shop, start, **settings):
    """(posterior, the shop's record or None): in a shop database the campaign's cuts so far and these, from its
    current posterior, recorded in one transaction with each cut's condition and stickout (its notes printed);
    else an update of these cuts. ``settings``: engine, samples, seed, sampler, engine_options (the --engine-option
    texts, checked here before any work against the engine: one line naming --engine-option); ``source``: the cuts
    file's path, recorded in the update's event (a cut traced to its file)."""
    from millstab import api

    settings["engine_options"] = api.check_engine_options(settings["engine"],
                                                          engine_option_pairs(settings.get("engine_options")))
    settings = api.UpdateSettings(**settings)
    if shop_target(db, campaign):
        from millstab.api.shop import CutsBy, update_in_db

        src = None if source is None else str(Path(source).expanduser().resolve())  # the same file on another day
        done = update_in_db(db, campaign, cfg, cuts, points, settings=settings, by=CutsBy(user=user, source=src),
                            client=client, shop=shop)
        for line in done.notes:
            typer.echo(line)
        return done.posterior, done
    post = api.update(cfg, cuts, points, client=client, start=_load_posterior(start) if start is not None else None,
                      **settings.keywords())
    return post, None


@app.command("map")
def map_cmd(
    posterior: Optional[Path] = typer.Argument(None, help="Posterior JSON from millstab update (or --db/--campaign)."),
    rpm: str = typer.Option(..., "--rpm", help="Speeds START:STOP:STEP [rpm]."),
    depth: str = typer.Option(..., "--depth", help="Depths START:STOP:STEP [mm], e.g. 0:6:0.05."),
    out: Optional[Path] = typer.Option(None, "--out", help="CSV rpm,depth_mm,p_stable (this, --plot or both)."),
    plot: Optional[Path] = typer.Option(None, "--plot",
                                        help="P(stable) map with the 5/50/95 % boundaries (.png/.svg/.pdf)."),
    stickout: StickoutOpt = None,
    dask: DaskOpt = None,
    workers: WorkersOpt = None,
    db: ShopDbOpt = None,
    campaign: CampaignOpt = None,
    radial_immersion: RadialImmersionOpt = None,
    milling: MillingOpt = None,
    entry_deg: EntryDegOpt = None,
    exit_deg: ExitDegOpt = None,
    teeth: TeethOpt = None,
    radial_width: RadialWidthOpt = None,
    options: EngineOptionOpt = None,
    samples: str = typer.Option("auto", "--samples", help="Posterior samples the map reads: auto (every sample from "
                                "zoa, a seeded subsample of 500 from spectral or sdm: each cell's Monte Carlo error "
                                "is then at most 0.5/sqrt(500) = 0.022, printed), all, or a whole number."),
) -> None:
    """The probability of a stable cut on a speed × depth grid, from posterior samples."""
    from rich.console import Console

    from millstab import api
    from millstab.io import check_outputs, write_csv

    if out is None and plot is None:  # an hour's map that writes nothing is refused before the work
        raise InputError("--out", None, "give --out CSV, --plot FIGURE or both: the map is written, not printed")
    speeds = api.parse_rpm_range(rpm)
    depths = api.parse_grid(depth, "--depth", "mm", example="0:6:0.05")
    post, inputs, _ = posterior_source(posterior, db, campaign)
    post = for_decision(post, stickout, radial_immersion, milling, entry_deg, exit_deg, teeth, options, radial_width)
    check_outputs(inputs, {"--out": out, "--plot": plot}, figures=("--plot",))
    protect = list(inputs.values())
    used = api.map_samples_text(post, samples)  # a bad --samples is refused before any work
    with _client(dask, workers) as client:  # the samples' limits on a cluster where that pays (sdm, spectral)
        pm = api.p_stable(post, speeds, depths, client, samples=samples)
    con = Console()
    if out:
        write_csv(out, *api.map_table(speeds, depths, pm), protect=protect)
    con.print(f"{'wrote ' + str(out) if out else 'P(stable)'} ({speeds.size} speeds × {depths.size} depths, {used}; "
              f"{api.condition_line(post)})")
    if plot:
        from millstab.io.figures import save_figure

        fig = api.map_figure(post, speeds, depths, pm,
                             title=f"P(stable) from {posterior.name if posterior else campaign}")
        save_figure(fig, plot, protect=protect)
        con.print(f"wrote {plot}")
