"""``millstab listen``: chatter and its frequency from a recording of a cut, and a speed to try.

millstab listen REC --rpm R --teeth Z [--start S --end E] [--channel C] [--config CFG] [--tap TAP]
                [--rpm-range MIN:MAX]
                [--post post.json --depth MM [--risk P]] [--out res.json] [--plot spec.png]
                [--db shop.db --campaign NAME --depth MM [--stickout MM] [--new-campaign] [--user U]]
                (records the cut with its heard label)
"""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from millstab.cli.app import app
from millstab.cli.history import CampaignOpt, ShopDbOpt, UserOpt, shop_target


@app.command()
def listen(
    recording: Path = typer.Argument(..., help="WAV (PCM 8/16/24/32-bit or float, 8-192 kHz) or CSV time_s,signal."),
    rpm: float = typer.Option(..., "--rpm", help="Spindle speed of the cut (rev/min; may be off by ~1 %)."),
    teeth: int = typer.Option(..., "--teeth", help="Number of teeth of the tool."),
    start: Optional[float] = typer.Option(None, "--start", help="Start of the cut in the recording (s); "
                                                                "default: found from the tooth-passing sound."),
    end: Optional[float] = typer.Option(None, "--end", help="End of the cut in the recording (s)."),
    channel: int = typer.Option(0, "--channel", help="Channel of a multi-channel WAV (0 = first)."),
    config: Optional[str] = typer.Option(None, "--config", help="The tool's config (TOML or example:NAME): a "
                                                                 "flip chatter is reported at its member nearest "
                                                                 "the modes."),
    tap: Optional[Path] = typer.Option(None, "--tap", help="A tap (hammer hit on the tool) recorded by the same "
                                                           "sensor at the same place and sample rate: the sensor "
                                                           "path it measures is divided out when the chatter "
                                                           "family's member is chosen (docs/listen.md)."),
    rpm_range: Optional[str] = typer.Option(None, "--rpm-range", help="Machine speed range MIN:MAX for the "
                                                                      "suggestion (rev/min; default 0.5-1.5 x rpm)."),
    post: Optional[Path] = typer.Option(None, "--post", help="Posterior JSON of millstab update: suggest "
                                                             "recommend's speed at --depth instead."),
    depth: Optional[float] = typer.Option(None, "--depth", help="Depth of the cut (mm), with --post."),
    risk: float = typer.Option(0.1, "--risk", help="Tolerated P(chatter) of the suggestion, with --post."),
    out: Optional[Path] = typer.Option(None, "--out", help="JSON of the result."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Spectrum figure (.png, .svg or .pdf)."),
    db: ShopDbOpt = None,
    campaign: CampaignOpt = None,
    user: UserOpt = None,
    stickout: Optional[float] = typer.Option(None, "--stickout", help="Tool stickout of the cut [mm] (holder face to "
                                                                      "tip), recorded with it (--db; a campaign over "
                                                                      "the holder: [tool] + [[holder.modes]]); "
                                                                      "default: the config's."),
    new_campaign: bool = typer.Option(False, "--new-campaign", help="With --db: start --campaign when the database "
                                                                    "holds others but not it (else a misspelt name "
                                                                    "is refused)."),
) -> None:
    """Listen to a recorded cut: stable, marginal or chatter, the chatter frequency and a speed to try. With
    --db/--campaign/--depth the cut is recorded in the campaign with the label heard (and the suggestion
    uses the campaign's current posterior)."""
    from millstab import api
    from millstab.cli import emit
    from millstab.io import config_inputs

    cfg = api.config(config) if config is not None else None  # --config: the tool's structure (docs/listen.md)
    protect = emit.checked({"RECORDING": recording, "--post": post, "--tap": tap, **config_inputs(cfg)},
                           {"--out": out, "--plot": plot}, figures=("--plot",))
    on_db = shop_target(db, campaign)
    posterior = _posterior(post, on_db, db, campaign, depth, teeth, stickout, new_campaign, user)
    heard = api.listen_file(recording, rpm, teeth, channel=channel, start=start, end=end, rpm_range=rpm_range, tap=tap,
                            post=posterior, depth_mm=depth, risk=risk, structure=getattr(cfg, "structure", None))
    typer.echo(f"{recording.name}: {heard.summary()}")
    if on_db:
        from millstab.api import shop

        n = shop.record_heard(db, campaign, heard, depth, recording, user=user, stickout_mm=stickout)
        at = "" if stickout is None else f", stickout {stickout:g} mm"
        typer.echo(f"recorded in campaign {campaign} as cut {n}: {heard.listening.rpm:g} rpm, {depth:g} mm{at}, "
                   f"{heard.listening.label} (the next `millstab update --db` uses it)")
    emit.json(out, lambda: heard.to_json(spectrum=False), protect)
    emit.figure(plot, lambda: api.listen_figure(heard, title=recording.name), protect)


def _posterior(post: Path | None, on_db: bool, db, campaign, depth, teeth: int, stickout, new_campaign: bool, user):
    """The posterior of the suggestion (``None``: the harmonizer's): --post's, or with --db/--campaign the campaign's
    current one, after the campaign, --teeth and --stickout are checked (:func:`millstab.api.shop.heard_target`:
    a misspelt --campaign made a new campaign of one cut, silently)."""
    from millstab import api
    from millstab.errors import InputError
    from millstab.io import read_json

    if stickout is not None and not on_db:
        raise InputError("--stickout", stickout, "the stickout of a cut recorded with --db/--campaign/--depth")
    if on_db and (depth is None or post is not None):
        raise InputError("--depth" if depth is None else "--post", depth if depth is None else str(post),
                         "with --db/--campaign: give --depth MM (the cut's depth, to record it) and no --post (the "
                         "campaign's current posterior is used)")
    if not on_db:
        return api.posterior_from_json(read_json(post), str(post)) if post is not None else None
    from millstab.api import shop

    current = shop.heard_target(db, campaign, teeth, stickout_mm=stickout, new_campaign=new_campaign, user=user)
    return None if current is None else current[1]
