"""Options several commands share, validated once: ``--seed`` (every random process), ``--samples``
(the Bayesian updating's particles), each refused with one line before any work, and ``--dask`` /
``--workers`` (where a study runs) with the client they open."""

from __future__ import annotations

import sys
from contextlib import contextmanager
from typing import Annotated, Any, Iterator, Optional

import typer

from millstab.errors import InputError


def seed_callback(value):
    """typer callback of ``--seed``: the value, or InputError (one line, exit 2)."""
    from millstab import api

    return api.check_seed(value, "--seed")


def seed_option(default: int | None, help: str) -> Any:
    """A ``--seed`` option whose value is checked by :func:`millstab.api.check_seed` (0 ≤ seed < 2**32)."""
    return typer.Option(default, "--seed", help=help + " A whole number in 0..4294967295.", callback=seed_callback)


def samples_callback(value):
    """typer callback of ``--samples``: the value, or InputError when too few, too many or more than the
    machine's memory holds (:func:`millstab.bounds.samples`)."""
    from millstab import api

    return api.check_samples(value, "--samples")


def count(text: str):
    """A count as written: ``4000``, ``4e3``, ``4_000`` → 4000; anything else is handed on as text, for the
    option's callback to refuse in one line (a parser that raised would print typer's usage panel)."""
    try:
        value = float(str(text).replace("_", ""))
    except ValueError:
        return text
    return int(value) if value.is_integer() else text


def samples_option(default: int, help: str) -> Any:
    """A ``--samples`` option of the Bayesian updating checked by :func:`millstab.bounds.samples` (``1e8``
    reads as 100000000 and is refused for the memory it needs, not for its spelling)."""
    return typer.Option(default, "--samples", help=help + " 100..1000000, as memory allows.", parser=count,
                        callback=samples_callback)


def engine_option_pairs(texts) -> dict:
    """The ``--engine-option`` texts (repeatable) as a table (:func:`millstab.api.engine_option_pairs`):
    ``["steps=40"]`` → ``{"steps": 40}``; which keywords and values an engine takes is checked where the engine
    is known (:func:`millstab.api.check_engine_options`)."""
    from millstab import api

    return api.engine_option_pairs(texts, "--engine-option")


def _engine_option_callback(texts):
    """typer callback of ``--engine-option``: the texts as given, after :func:`engine_option_pairs` checked their
    form (typer turns a callback's table back into a list: the commands read the texts with it)."""
    engine_option_pairs(texts)
    return texts


#: what --engine-option takes, in its help (= millstab.api.ENGINE_OPTION_FORM, not imported: the help is built
#: when the CLI loads, before any service module; tests/test_web_api.py checks that the two agree)
ENGINE_OPTION_FORM = "KEY=VALUE with a number, e.g. steps=40 (sdm: steps, fn_max_hz; spectral: nodes, near; zoa: none)"


EngineOptionOpt = Annotated[Optional[list[str]], typer.Option(
    "--engine-option", metavar="KEY=VALUE", callback=_engine_option_callback,
    help="The engine's discretisation, repeatable: " + ENGINE_OPTION_FORM + ". On update: fixed for the whole "
         "update and kept in the posterior, whose decisions use it; on a decision: over the posterior's.")]


DaskOpt = Annotated[Optional[str], typer.Option(
    "--dask", metavar="ADDRESS",
    help="Run on the Dask cluster whose scheduler is at ADDRESS (e.g. tcp://10.0.0.5:8786); "
         "needs millstab[dask]. Same numbers as a local run.")]
WorkersOpt = Annotated[Optional[int], typer.Option(
    "--workers", help="Run on a local Dask cluster of N worker processes started for this run; needs millstab[dask]. "
                      "Same numbers as a local run.")]


@contextmanager
def dask_client(dask: str | None, workers: int | None) -> Iterator:
    """The run's Dask client (None without --dask/--workers: then dask is not imported); says on stderr
    where the work goes."""
    if dask is None and workers is None:
        yield None
        return
    from millstab import api

    if sys.stderr.isatty():  # on a terminal only: a pipe's stderr keeps an error to one line
        typer.echo(f"Dask: connecting to {dask} (at most ~{api.CONNECT_SECONDS:g} s)…" if dask else
                   f"Dask: starting {workers} local workers…", err=True)
    with api.open_client(dask, workers) as client:
        threads = client.nthreads()  # asked of the scheduler (scheduler_info() is the client's copy, seconds old)
        where = f"scheduler {dask}" if dask else "a local cluster started for this run"
        typer.echo(f"Dask: {len(threads)} workers, {sum(threads.values())} threads ({where})", err=True)
        yield client


# --- a cutting condition named on the command line: a decision's target (map, recommend, predict; docs/updating.md
# "Many conditions"), an SLD's (lobes), a simulated cut's (simulate); the same names and rules everywhere
# (api.target_condition), the help in the command's own words ---
def condition_options(doing: str, default: str, panel: str) -> tuple:
    """(--radial-immersion, --milling, --entry-deg, --exit-deg, --teeth) as typer option types whose help reads
    "``doing`` for this radial immersion …", ``default`` saying what applies without them."""
    def opt(kind, name: str, text: str):
        return Annotated[Optional[kind], typer.Option(name, help=f"{doing} {text}", rich_help_panel=panel)]

    return (opt(float, "--radial-immersion", f"for this radial immersion a/D in (0, 1] (1 = slot; with --milling, else "
                                              f"the config's direction; default: {default})."),
            opt(str, "--milling", "for up or down milling (climb = down, conventional = up; with --radial-immersion, "
                                  "or alone: the config's a/D)."),
            opt(float, "--entry-deg", "for this entry angle [deg] (with --exit-deg; instead of a/D and milling)."),
            opt(float, "--exit-deg", "for this exit angle [deg] (with --entry-deg)."),
            opt(int, "--teeth", "for a tool of this family (the config's Kt and Kr) with this many teeth."))


RadialImmersionOpt, MillingOpt, EntryDegOpt, ExitDegOpt, TeethOpt = condition_options(
    "Decide", "the posterior's condition, the config's", "Target condition")
#: map's and predict's --radial-width (recommend's also sets its removal rate: its own help)
RadialWidthOpt = Annotated[Optional[float], typer.Option(
    "--radial-width", rich_help_panel="Target condition",
    help="Decide for this radial width of cut [mm]: with the config's tool diameter, the a/D = width/diameter (with "
         "--milling or the posterior's direction; given with --radial-immersion or the angles it must agree).")]


StickoutOpt = Annotated[Optional[float], typer.Option(
    "--stickout", help="Decide at this tool stickout [mm] (a posterior over the holder, from a [tool] + "
                       "[[holder.modes]] config).", rich_help_panel="Target condition")]


def for_decision(post, stickout=None, radial_immersion=None, milling=None, entry_deg=None, exit_deg=None, teeth=None,
                 engine_options=None, radial_width=None):
    """The posterior deciding for the target options of map, recommend and predict: at the stickout
    (:func:`millstab.api.at_stickout`), in the cutting condition (:func:`millstab.api.for_condition`;
    ``--radial-width`` with the config's tool diameter among them), with the ``--engine-option`` texts over the
    options it was fitted with (:func:`millstab.api.with_engine_options`)."""
    from millstab import api

    post = api.with_engine_options(api.at_stickout(post, stickout), engine_option_pairs(engine_options))
    return api.for_condition(post, radial_immersion=radial_immersion, milling=milling, entry_deg=entry_deg,
                             exit_deg=exit_deg, teeth=teeth, radial_width_mm=radial_width)
