"""``millstab app``: serve the browser interface (needs the ``millstab[app]`` extra: Panel)."""

from __future__ import annotations

import sys
from pathlib import Path

import typer

from millstab.cli.app import app
from millstab.errors import InputError


@app.command("app")
def app_cmd(
    port: int = typer.Option(5006, "--port", help="TCP port (0: a free one)."),
    host: str = typer.Option("127.0.0.1", "--host", help="Address to bind; the default serves this machine only. Any "
                                                        "other (0.0.0.0: every network interface) needs --users."),
    users: Path = typer.Option(None, "--users", help="Users file (name:hash lines): every page then needs a login. "
                                                     "Required for a --host other than 127.0.0.1, localhost, ::1."),
    add_user: str = typer.Option(None, "--add-user", metavar="NAME", help="Add NAME (or change its password) in the "
                                 "--users file, asking for the password, and exit."),
    password_stdin: bool = typer.Option(False, "--password-stdin", help="With --add-user: read the password from the "
                                        "first line of standard input (scripts) instead of asking."),
    shop: list[str] = typer.Option(None, "--shop", help="With --add-user: a shop the user belongs to (repeat for "
                                   "several; default: those it had, else the shop 'default'). With --db a user sees "
                                   "and writes only their shops' campaigns."),
    db: str = typer.Option(None, "--db", help="Shop database (a file, created when new, or a SQLAlchemy URL): the "
                                              "Update tab lists, opens and updates its campaigns. See docs/app.md."),
    behind_proxy: bool = typer.Option(False, "--behind-proxy", help="Served behind a reverse proxy (nginx, Caddy): "
                                      "each client's address, which the login throttle counts, is read from the "
                                      "proxy's X-Forwarded-For / X-Real-Ip header, and HTTPS from its "
                                      "X-Forwarded-Proto (login cookies then Secure). Only behind a proxy that sets "
                                      "them."),
    secure_cookies: bool = typer.Option(False, "--secure-cookies", help="Login cookies always Secure (sent over "
                                        "HTTPS only): behind an HTTPS proxy that sends no X-Forwarded-Proto."),
    origin: list[str] = typer.Option(None, "--origin", metavar="HOST[:PORT]", help="A name the browser reaches the "
                                     "page under, beside the address served (repeat for several): behind a reverse "
                                     "proxy its public name (shop.example.com). The page's websocket is refused from "
                                     "other origins and the page stays blank; with --host 0.0.0.0 this machine's "
                                     "names and addresses are allowed."),
    no_browser: bool = typer.Option(False, "--no-browser", help="Do not open a browser tab."),
) -> None:
    """Serve the stability tools as a web page (tool and cut, lobes, identify, update, downloads); prints the URL."""
    from millstab.web import auth

    if add_user is not None:
        return _add_user(users, add_user, password_stdin, shop)
    if password_stdin:
        raise InputError("--password-stdin", True, "only with --add-user NAME --users FILE")
    if secure_cookies and users is None:
        raise InputError("--secure-cookies", True, "only with --users FILE (the cookies are the login's)")
    if shop:
        raise InputError("--shop", ",".join(shop), "only with --add-user NAME --users FILE (the users file holds "
                                                   "each user's shops)")
    if not 0 <= port <= 65535:
        raise InputError("--port", port, "must be a TCP port 0..65535")
    accounts = auth.read_accounts(users) if users is not None else None
    try:
        import panel  # noqa: F401
    except ImportError:
        raise InputError("millstab app", "panel not installed",
                         "install the app extra: pip install 'millstab[app]'") from None
    from millstab.web import serve

    origins = _origins(origin, behind_proxy)  # before the server starts

    serve(port=port, host=host, show=not no_browser,
          users={n: h for n, (h, _) in accounts.items()} if accounts else None,
          db=db, shops={n: s for n, (_, s) in accounts.items()} if accounts else None, proxy=behind_proxy,
          secure_cookies=secure_cookies, origins=origins)


def _origins(origin: list[str] | None, behind_proxy: bool) -> list[str]:
    """``--origin``'s values checked (:func:`millstab.web.check_origin`); behind a proxy without one, a warning: the
    browser reaches the page under the proxy's name, from which the page's websocket would be refused."""
    from millstab.web import check_origin

    origins = [check_origin(o) for o in origin or ()]
    if behind_proxy and not origins:
        typer.echo("millstab app: warning: behind a proxy the browser reaches the page under the proxy's name: give "
                   "it with --origin NAME (e.g. --origin shop.example.com), or the page's websocket is refused and "
                   "the page stays blank", err=True)
    return origins


def _add_user(users: Path | None, name: str, password_stdin: bool, shops: list[str] | None) -> None:
    """``--add-user NAME --users FILE``: add NAME (or change its password) in the users file, and exit."""
    from millstab.web import auth

    if users is None:
        raise InputError("--add-user", name, "give the file too: --users FILE")
    auth.check_name(name)
    if password_stdin:
        password = sys.stdin.readline().rstrip("\r\n")
    else:
        password = typer.prompt(f"password for {name}", hide_input=True, confirmation_prompt=True)
    path = auth.add_user(users, name, password, shops)
    print(f"millstab app: {name} added to {path}; serve with --users {path}")
