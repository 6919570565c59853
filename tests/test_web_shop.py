"""The shop's memory in the app (issue 31.3 and 31.4), in a real browser (Playwright driving Debian's chromium):
``millstab app --db`` lists the signed-in user's campaigns, starts one from the tab's config and cuts, opens it
again in a new browser context (another computer) from its address, adds cuts and updates it in the database;
a user of another shop cannot open it by guessing its address, nor take its name. Screenshots go to
.test-artifacts/web/ (gitignored)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from millstab.web.testing import CHROMIUM, LAUNCH

pytestmark = [pytest.mark.skipif(not CHROMIUM.exists(), reason=f"no chromium at {CHROMIUM} (apt-get install chromium)"),
              pytest.mark.slow]
pytest.importorskip("panel")
pytest.importorskip("pytest_playwright")
pytest.importorskip("sqlalchemy")
pytest.importorskip("alembic")

from millstab import api  # noqa: E402
from millstab.api import shop  # noqa: E402
from millstab.shopdb import open_store  # noqa: E402
from millstab.web import testing as T  # noqa: E402

from test_shopdb import land, some_cuts  # noqa: E402

ARTIFACTS = Path(__file__).resolve().parents[1] / ".test-artifacts" / "web"


@pytest.fixture(scope="session")
def browser_type_launch_args(browser_type_launch_args):
    return {**browser_type_launch_args, **LAUNCH}


def shot(page, name: str) -> None:
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / f"{name}.png"), full_page=True)


def cuts_csv(path: Path, rpm, factor: float) -> Path:
    """Cuts of example ex3 labelled by its own limit: at ``factor`` × the limit (stable below 1, chatter above)."""
    cfg = api.config("example:ex3")
    rpm = np.asarray(rpm, float)
    blim = api.lobes(cfg, rpm).envelope.depth_mm
    lab = "stable" if factor < 1 else "chatter"
    path.write_text("rpm,depth_mm,label\n" + "".join(f"{r:g},{factor * b:.6g},{lab}\n" for r, b in zip(rpm, blim)))
    return path


def login(browser, url: str, name: str, password: str):
    page = browser.new_context(viewport={"width": 1400, "height": 1100}).new_page()
    page.set_default_timeout(90_000)
    page.goto(url)
    page.locator("input[name=username]").fill(name)
    page.locator("input[name=password]").fill(password)
    page.locator("button[type=submit]").click()
    page.locator(".tool-status").filter(has_text="valid").wait_for()
    T.tab(page, "Update and recommend")
    page.locator(".campaign-who").filter(has_text=f"signed in as {name}").wait_for()
    return page


def options(page) -> list[str]:
    return [o.strip() for o in page.locator(".campaign-select select option").all_inner_texts()]


def test_campaigns_are_remembered_per_shop_in_the_browser(browser, tmp_path):
    from millstab.web import auth

    db = tmp_path / "shop.db"
    with open_store(db, user="bob") as s:  # another shop's campaign, made on the command line side
        land(s, "b1", some_cuts(5, 4), 4, shop="bolt")
    users = tmp_path / "users.txt"
    auth.add_user(users, "anna", "anna's password", ["acme"])
    auth.add_user(users, "bob", "bob's password", ["bolt"])
    acc = auth.read_accounts(users)
    rpm = [5000.0, 7000, 9000, 11000, 14000, 17000, 19000]
    with T.running_app(users={n: h for n, (h, _) in acc.items()}, db=str(db),
                       shops={n: s for n, (_, s) in acc.items()}) as url:
        # anna starts campaign t12-m1 from the tab's config (example ex3) and 14 cuts
        page = login(browser, url, "anna", "anna's password")
        assert options(page) == []  # b1 is bolt's
        T.upload(page, "drop-cuts", _both(tmp_path, rpm))
        page.locator(".cuts-note").filter(has_text="14 points").wait_for()
        T.set_samples(page, 200)
        page.locator(".campaign-new-name input").fill("t12-m1")
        page.locator(".campaign-new-name input").press("Enter")
        page.locator(".campaign-create button").click()
        page.locator(".campaign-status").filter(has_text="update recorded").wait_for(timeout=240_000)
        page.locator(".campaign-summary").filter(has_text="14 cuts, 1 update(s)").wait_for()
        page.locator(".campaign-history").filter(has_text="recommend").wait_for(timeout=120_000)
        assert "?campaign=t12-m1" in page.url
        shot(page, "campaign_started")
        mine = shop.ShopView(db, "x", ["acme"]).open("t12-m1")
        assert (mine.shop, mine.revision, len(mine.cuts), mine.posterior_rows) == ("acme", 1, 14, 14)
        assert [e.user for e in mine.events] == ["anna"] * 3 and [e.action for e in mine.events] == \
            ["recommend", "update", "create"]
        # the page's posterior table is the recorded posterior's (its medians)
        med = np.median(np.asarray(mine.posterior.samples), axis=0)
        shown = T.text(page, "post-table")
        assert re.search(r"computed for: campaign t12-m1", shown), shown
        cells = {r[0]: r[1:] for r in (row.locator("td").all_inner_texts()
                                       for row in page.locator(".post-table tr").all()) if r}
        for name, v in zip(mine.posterior.names, med):  # as the form writes them: k in N/µm (was N/m, unit-less)
            want = {"k": (f"{v * 1e-6:.5g}", "N/µm"), "f": (f"{v:.5g}", "Hz"), "z": (f"{v:.5g}", "")}[name[0]]
            assert (cells[name][1], cells[name][3]) == want, (name, cells)
        # a guessed address of bolt's campaign shows nothing of it: the words of a campaign that does not exist
        page.goto(url + "?campaign=b1")
        page.locator(".tool-status").filter(has_text="valid").wait_for()
        T.tab(page, "Update and recommend")
        page.locator(".campaign-status").filter(has_text="no such campaign").wait_for()
        assert "b1" not in T.text(page, "campaign-summary") and T.text(page, "campaign-history") == ""
        shot(page, "campaign_of_another_shop")
        page.context.close()

        # the tab closed; anna opens the campaign again in a new context (another computer) by its address
        page = login(browser, url + "?campaign=t12-m1", "anna", "anna's password")
        page.locator(".campaign-summary").filter(has_text="14 cuts, 1 update(s)").wait_for()
        page.locator(".post-table").filter(has_text="median").wait_for()
        assert T.text(page, "tool-status").startswith("valid") and "campaign t12-m1" in T.text(page, "post-table")
        # four more cuts, then Update: recorded in the campaign, continuing from its posterior
        T.upload(page, "drop-cuts", cuts_csv(tmp_path / "more.csv", [6000.0, 8000, 12000, 16000], 1.3))
        page.locator(".cuts-note").filter(has_text="4 points").wait_for()
        T.set_samples(page, 200)
        page.locator(".update-run button").click()
        page.locator(".campaign-summary").filter(has_text="18 cuts, 2 update(s)").wait_for(timeout=240_000)
        shot(page, "campaign_updated")
        page.context.close()
        again = shop.ShopView(db, "x", ["acme"]).open("t12-m1")
        assert (again.revision, len(again.cuts), again.posterior_rows) == (2, 18, 18)
        upd = [e for e in again.events if e.action == "update"][0]
        assert f"from posterior {mine.posterior_id}" in upd.detail, upd.detail  # sequential, not from the prior

        # bob (shop bolt): only b1 listed; anna's campaign by its address shows nothing, its name is not his
        page = login(browser, url + "?campaign=t12-m1", "bob", "bob's password")
        page.locator(".campaign-status").filter(has_text="no such campaign").wait_for()
        said = T.text(page, "campaign-status")
        assert options(page) == ["b1"] and said.count("t12-m1") == 1 and "holds 1 campaign(s): b1" in said, said
        assert str(tmp_path) not in said  # no server path on the page
        assert page.locator(".campaign-select select").input_value() == "b1"
        assert T.text(page, "post-table") == ""
        T.upload(page, "drop-cuts", _both(tmp_path, rpm))
        page.locator(".cuts-note").filter(has_text="14 points").wait_for()
        page.locator(".campaign-new-name input").fill("t12-m1")
        page.locator(".campaign-new-name input").press("Enter")
        page.locator(".campaign-create button").click()
        page.locator(".update-status").filter(has_text="taken by a campaign you cannot see").wait_for(timeout=60_000)
        shot(page, "campaign_other_user")
        page.context.close()
    assert shop.ShopView(db, "x", ["acme"]).open("t12-m1").revision == 2


def _both(tmp_path: Path, rpm) -> Path:
    low = cuts_csv(tmp_path / "a.csv", rpm, 0.6).read_text().splitlines()
    high = cuts_csv(tmp_path / "b.csv", rpm, 1.4).read_text().splitlines()[1:]
    out = tmp_path / "cuts14.csv"
    out.write_text("\n".join(low + high) + "\n")
    return out


def test_single_user_app_on_this_machine_lists_every_campaign(browser, tmp_path):
    """Without accounts (127.0.0.1) the app is one user's: every campaign of the database is listed and opens,
    its cuts table showing each cut's own condition and stickout (empty: the config's)."""
    db = tmp_path / "shop.db"
    with open_store(db, user="bob") as s:
        land(s, "b1", some_cuts(5, 4), 4, shop="bolt")
        s.add_cuts("c1", some_cuts(1, 5))
        s.add_cuts("c1", api.points_from_text("rpm,depth_mm,label,radial_immersion,milling,stickout_mm\n"
                                              "9000,1.5,chatter,0.25,up,62.5\n9500,0.5,stable,,,\n"))
    with T.running_app(db=str(db)) as url:
        page = browser.new_context(viewport={"width": 1400, "height": 1000}).new_page()
        page.set_default_timeout(90_000)
        T.open_app(page, url + "?campaign=c1")
        T.tab(page, "Update and recommend")
        page.locator(".campaign-summary").filter(has_text="3 cuts, 0 update(s), no posterior yet").wait_for()
        assert options(page) == ["b1", "c1"]
        table = page.locator(".campaign-cuts table")
        heads = [h.strip() for h in table.locator("th").all_inner_texts()]
        assert heads[-4:] == ["radial_immersion", "milling", "stickout_mm", "created_by"], heads
        cells = [[c.strip() for c in r.locator("td").all_inner_texts()] for r in table.locator("tr").all()[1:]]
        assert cells[1][-4:] == ["0.25", "up", "62.5", "bob"] and cells[2][-4:] == ["", "", "", "bob"], cells
        shot(page, "campaign_single_user")
        page.context.close()
