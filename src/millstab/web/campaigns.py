"""The shop's memory in the app (``millstab app --db URL``, issue 31.3): the Update tab's campaign card.

It lists the campaigns the signed-in user may see, opens one (its cuts, current posterior, config and
history; also from the page's address, ``/?campaign=NAME``), records new cuts, updates the campaign in the
database, and starts a new campaign from the tab's config and cuts. Every read and write goes through one
:class:`millstab.api.shop.ShopView` bound to the user and their shops, so the per-shop rule is the service
layer's, not this page's: a campaign of another shop reads as no such campaign whatever the page asks.
"""

from __future__ import annotations

import panel as pn

from millstab import api
from millstab.api import shop
from millstab.errors import InputError
from millstab.web.common import TextBox, error_html, esc, html_table

#: history lines shown for an open campaign
EVENTS = 15
#: cut rows shown for an open campaign (the newest; a campaign is tens of cuts, a long one hundreds)
CUTS_SHOWN = 200


class CampaignPanel:
    """The campaign card of the Update tab. ``view``: the user's :class:`~millstab.api.shop.ShopView`;
    ``tab``: the :class:`~millstab.web.update_tab.UpdateTab` (its cuts, samples, seed, job and result panes);
    ``load_config(text, name, source)``: shows a campaign's config in the Tool and cut form."""

    def __init__(self, view: shop.ShopView, tab, load_config):
        self.v = view
        self.tab = tab
        self.load_config = load_config
        self.current: shop.OpenCampaign | None = None
        self.config_text: str | None = None  # the config text of the open campaign's current posterior
        who = esc(view.user) + (f" (shops: {esc(', '.join(view.shops))})" if view.shops is not None else "")
        self.header = pn.pane.HTML(f'<span class="ms-note">shop database {esc(_where(view.store.url))}; '
                                   f'signed in as {who}</span>', css_classes=["campaign-who"])
        self.select = pn.widgets.Select(label="campaign", options=[], width=220, css_classes=["campaign-select"])
        self.open_button = pn.widgets.Button(label="Open", width=90, css_classes=["campaign-open"])
        self.refresh_button = pn.widgets.Button(label="↻ list", width=70, css_classes=["campaign-refresh"])
        self.new_name = pn.widgets.TextInput(label="new campaign", placeholder="e.g. t12-m1", width=220,
                                             css_classes=["campaign-new-name"])
        shops = list(view.shops or ())
        self.new_shop = pn.widgets.Select(label="shop", options=shops, value=shops[0] if shops else None, width=120,
                                          visible=len(shops) > 1, css_classes=["campaign-new-shop"])
        self.create_button = pn.widgets.Button(label="Start it from the config and cuts", width=250,
                                               css_classes=["campaign-create"])
        self.record_button = pn.widgets.Button(label="Record the new cuts only", width=200, disabled=True,
                                               css_classes=["campaign-record"])
        self.status = TextBox("campaign-status", width=900, height=None)
        self.summary = TextBox("campaign-summary", width=900, height=None)
        self.history = TextBox("campaign-history", width=900, height=None)
        self.cuts = TextBox("campaign-cuts", width=900, height=None)  # the cuts as recorded, conditions included
        self.open_button.on_click(lambda e: self.open(self.select.value))
        self.refresh_button.on_click(lambda e: self.refresh())
        self.create_button.on_click(lambda e: self.create())
        self.record_button.on_click(lambda e: self.record())
        self.refresh()

    def error(self, exc: InputError) -> str:
        """An error as the page shows it: the database named as :func:`_where` says (no server path)."""
        url = self.v.store.url
        text = str(exc).replace(url, _where(url))
        # the store's hint names the command line; the page's list and "Start it" do that here
        return error_html(text.replace("; `millstab history --db DB` lists them, and an update creates one",
                                       "; the list above shows them"))

    # --- reading ---------------------------------------------------------------------------------------
    def refresh(self) -> None:
        """List the user's campaigns (newest state of the database)."""
        try:
            names = [c["name"] for c in self.v.campaigns()]
        except InputError as exc:
            self.status.text = self.error(exc)
            return
        self.select.options = names
        if self.current is not None and self.current.name in names:
            self.select.value = self.current.name
        elif self.select.value not in names:  # a Select given new options keeps a stale value: shown blank
            self.select.value = names[0] if names else None

    def open(self, name: str | None, record: bool = False) -> bool:
        """Open campaign ``name``: its cuts become the tab's cuts, its config the form's, its posterior the
        tab's posterior (with its map; ``record``: its recommendation recorded); the summary and history are
        shown. False (and the error shown) when
        it cannot be opened, e.g. a campaign of another shop: the page then shows nothing of it."""
        if not name:
            self.status.text = error_html("choose a campaign to open, or start a new one")
            return False
        try:
            oc = self.v.open(name, EVENTS)
        except InputError as exc:
            self.status.text = self.error(exc)
            return False
        self.current, self.config_text = oc, oc.config_toml
        self.status.text = ""
        if oc.config_toml is not None:
            try:
                self.load_config(oc.config_toml, f"{name}.toml", f"campaign {name}")
            except InputError as exc:
                self.status.text = error_html(f"the campaign's config does not load here: {exc}")
        s = self.tab.s
        self.tab.pending = None
        if len(oc.cuts):
            s.cuts = oc.cuts
        self.tab.cuts_note.object = (f'<span class="ms-done">campaign {esc(name)}: {len(oc.cuts)} cuts recorded; '
                                     'upload the new cuts to add them</span>')
        self.record_button.disabled = False
        self.show_summary()
        if self.select.value != name and name in self.select.options:
            self.select.value = name
        _set_address(name)
        if oc.posterior is not None:  # its next update continues with its engine and options unless changed
            self.tab.use_engine(oc.posterior.engine, oc.posterior.engine_options)
            self.tab.show((oc.posterior, self.tab.s.origin), [], record=record, post_id=oc.posterior_id)
        else:
            self.tab.clear_results()
        return True

    def reload_history(self) -> None:
        """Re-read the open campaign's history (a recommendation was recorded)."""
        import dataclasses

        try:
            events = self.v.history(self.current.name, EVENTS)
        except InputError as exc:
            self.status.text = self.error(exc)
            return
        self.current = dataclasses.replace(self.current, events=events)
        self.show_summary()

    def show_summary(self) -> None:
        oc = self.current
        waiting = len(oc.cuts) - oc.posterior_rows
        post = (f"posterior {oc.posterior_id} over {oc.posterior_rows} cuts" if oc.posterior is not None
                else "no posterior yet")
        self.summary.text = (f"<b>campaign {esc(oc.name)}</b> (shop {esc(oc.shop)}): {len(oc.cuts)} cuts, "
                             f"{oc.revision} update(s), {post}"
                             + (f"; {waiting} cut(s) wait for the next update" if waiting > 0 and oc.posterior else "")
                             + f"; last change {esc(oc.updated_at[:19].replace('T', ' '))} UTC")
        rows = [(e.at[:19].replace("T", " "), e.user, e.action, e.detail) for e in oc.events]
        left = "<style>table.ms-table.history td { text-align: left; }</style>"
        self.history.text = left + html_table(("at (UTC)", "user", "action", "detail"), rows, "history")
        self.cuts.text = cuts_html(oc.rows)

    # --- writing ---------------------------------------------------------------------------------------
    def update_work(self, name: str, cfg, new, settings, shop_name: str | None = None):
        """The worker's call of an update of campaign ``name`` (:meth:`ShopView.update`) with the tab's
        ``settings`` (:class:`millstab.api.UpdateSettings`, :meth:`UpdateTab.settings`): the campaign's own
        config text when the form holds the same config, so the update continues from its posterior."""
        text = self.config_text if self.current is not None and self.current.name == name and \
            _same_config(cfg, self.config_text) else None
        options = {"shop": shop_name} if shop_name else {}

        def work(progress):
            try:
                return self.v.update(name, cfg, new, settings=settings, progress=progress, config_toml=text,
                                     **options)
            except InputError as exc:  # shown by the job bar: without the server's path or a URL's password
                url = self.v.store.url
                clean = [str(x).replace(url, _where(url)) for x in (exc.value, exc.allowed)]
                raise type(exc)(exc.field, *clean) from None
        return work

    def updated(self, result) -> None:
        """After an update landed: re-open the campaign (cuts, posterior, history) and list it."""
        self.refresh()
        notes = "".join(f'<div class="ms-note">{esc(n)}</div>' for n in result.notes)
        if self.open(result.campaign, record=True):
            self.status.text = (f'<span class="ms-done">campaign {esc(result.campaign)}: update recorded '
                                f'(posterior {result.posterior_id}, +{result.new_cuts} cuts)</span>' + notes)

    def create(self) -> None:
        """Start a new campaign from the tab's config and cuts (an update, recorded)."""
        name = (self.new_name.value or "").strip()
        if not name:
            self.status.text = error_html("new campaign: give it a name, e.g. t12-m1")
            return
        if name in (self.select.options or []):
            self.status.text = error_html(f"campaign {name!r} exists: open it to add cuts")
            return
        self.tab.run_campaign(name, self.new_shop.value if self.v.shops else None, new=True)

    def record(self) -> None:
        """Record the uploaded cuts in the open campaign without an update."""
        oc, new = self.current, self.tab.pending
        if oc is None or new is None or not len(new):
            self.status.text = error_html("upload the new cuts first")
            return
        try:
            n = self.v.add_cuts(oc.name, new, expected_rows=len(oc.cuts))
        except InputError as exc:
            self.status.text = self.error(exc)
            return
        self.open(oc.name)
        self.status.text = (f'<span class="ms-done">campaign {esc(oc.name)}: {len(new)} cut(s) recorded, '
                            f'{n} in all</span>')

    def view(self):
        return pn.Card(self.header, pn.Row(self.select, self.open_button, self.refresh_button),
                       pn.Row(self.new_name, self.new_shop, self.create_button), self.record_button,
                       self.status.view(), self.summary.view(), self.cuts.view(), self.history.view(),
                       title="Campaign (shop database)", collapsible=False, css_classes=["campaign-card"])


def cuts_html(rows) -> str:
    """The campaign's cuts as recorded (:func:`millstab.api.shop.cut_table`): each cut's own condition and
    stickout in their columns, an empty cell where the cut was in the config's; the newest
    :data:`CUTS_SHOWN` when there are more."""
    if not rows:
        return ""
    header, body = shop.cut_table(rows[-CUTS_SHOWN:])
    cells = [["" if v is None else f"{v:.6g}" if isinstance(v, float) else str(v) for v in r] for r in body]
    more = (f'<div class="ms-note">the newest {CUTS_SHOWN} of {len(rows)} cuts</div>' if len(rows) > CUTS_SHOWN else "")
    note = ('<div class="ms-note">an empty condition or stickout cell: the config\'s value</div>'
            if set(header) & set(shop.OWN_COLUMNS) else "")
    return f"<b>cuts</b>{more}" + html_table(header, cells, "cuts") + note


def _where(url: str) -> str:
    """The database as the page may show it: a file's name, a URL without its password."""
    if "://" not in url:
        from pathlib import Path

        return Path(url).name
    scheme, _, rest = url.partition("://")
    return f"{scheme}://{rest.rpartition('@')[2]}"


def _same_config(cfg, text: str | None) -> bool:
    """Whether the form's config is the campaign's (the same TOML once both are written by the config writer)."""
    if text is None or cfg is None:
        return False
    try:
        return (api.config_toml(api.modal(cfg)[0])
                == api.config_toml(api.modal(api.config_from_text(text, "campaign"))[0]))
    except (InputError, ValueError):
        return False


def _set_address(name: str) -> None:
    """Put the open campaign in the page's address (``?campaign=NAME``): a bookmark opens it again."""
    loc = pn.state.location
    if loc is not None:
        try:
            loc.update_query(campaign=name)
        except Exception:  # noqa: BLE001 - no browser location (a notebook, a test without a page)
            pass


def requested_campaign() -> str | None:
    """The campaign named in the page's address (``/?campaign=NAME``), if any."""
    args = getattr(pn.state, "session_args", None) or {}
    got = args.get("campaign")
    if not got:
        return None
    v = got[0]
    return (v.decode("utf-8", "replace") if isinstance(v, bytes) else str(v)).strip() or None
