"""The page: one :class:`~millstab.web.state.Session` and the five tabs per browser tab."""

from __future__ import annotations

import panel as pn

from millstab.web.common import CSS
from millstab.web.downloads import DownloadsTab
from millstab.web.identify_tab import IdentifyTab
from millstab.web.lobes_tab import LobesTab
from millstab.web.plots import preview_figure
from millstab.web.state import Session
from millstab.web.tool import ToolTab
from millstab.web.update_tab import UpdateTab


def create_app(db: str | None = None, shops: dict[str, tuple[str, ...]] | None = None):
    """Build one browser tab's page (``pn.serve`` calls this per session). ``db``: the shop database whose
    campaigns the Update tab opens and updates; ``shops``: {user: their shops} when the app has accounts
    (the signed-in user then sees only their shops' campaigns; a user not listed sees none), ``None`` for
    the single-user app on this machine (every campaign)."""
    pn.extension("filedropper", raw_css=[CSS], notifications=False)
    session = Session()
    tool = ToolTab(session)  # validates the form and sets session.cfg first, so the other tabs start drawn
    lobes = LobesTab(session)
    ident = IdentifyTab(session)
    update = UpdateTab(session)
    downloads = DownloadsTab(session)
    closing = [session.close]
    if db is not None:
        from millstab.api.shop import ShopView
        from millstab.web.campaigns import CampaignPanel, requested_campaign

        from millstab.web.auth import signed_in_user

        user = signed_in_user() if shops is not None else None  # the signed login only (never an is_guest cookie)
        view = ShopView(db, user, shops.get(user, ()) if shops is not None else None)
        update.campaign = CampaignPanel(view, update, tool.load_text)
        closing.append(view.store.close)
    doc = pn.state.curdoc
    if doc is not None:
        doc.on_session_destroyed(lambda ctx: [close() for close in closing])
    preview = preview_figure(lobes.src)
    if session.lobes is not None:
        lobes.show(session.lobes, origin=session.origin)  # fill the preview's source too
    tabs = pn.Tabs(tool.view(preview), lobes.view(), ident.view(), update.view(), downloads.view(), dynamic=False,
                   css_classes=["ms-tabs"], sizing_mode="stretch_width")
    header = pn.pane.HTML("<h2 style='margin:4px 0'>millstab: milling stability</h2>"
                          "<span class='ms-note'>Tool and cut → Lobes → Identify → Update and recommend → Downloads"
                          "</span>" + _login_line(), css_classes=["ms-header"])
    page = pn.Column(header, tabs, sizing_mode="stretch_width", css_classes=["ms-page"])
    if update.campaign is not None and (wanted := requested_campaign()):
        update.campaign.open(wanted)  # /?campaign=NAME: the user's own campaigns only (the service's rule)
    page.session = session  # for tests and notebooks
    page.tabs = {"tool": tool, "lobes": lobes, "identify": ident, "update": update, "downloads": downloads}
    return page


def _login_line() -> str:
    """The header's "signed in as NAME · Log out" when the app has accounts (else empty): the logout, which ends the
    login on the server, was reachable only by typing /logout. The link is relative, so it keeps a proxy's path."""
    from millstab.web.auth import signed_in_user
    from millstab.web.common import esc

    user = signed_in_user()
    if user is None:
        return ""
    return (f"<span class='ms-note ms-login'> · signed in as {esc(user)} · "
            "<a href='logout' class='ms-logout'>Log out</a></span>")
