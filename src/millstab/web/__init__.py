"""``millstab app``: the stability tools in a browser (Panel + Bokeh), served by the package itself.

The page calls the service layer (:mod:`millstab.api`) only: the same validators, numbers and files as
the command line. Each browser tab has its own session state; long work runs in worker threads with
progress and cancel. Importing :mod:`millstab.web.app` imports Panel (the ``millstab[app]`` extra); this
module does not.
"""

from __future__ import annotations

import errno
import socket

from millstab.errors import InputError

#: the address the app binds to unless told otherwise: this machine only
DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 5006


def free_port(host: str = DEFAULT_HOST) -> int:
    """A TCP port free on ``host`` now."""
    with socket.socket(_family(host)) as s:
        s.bind((host, 0))
        return s.getsockname()[1]


def _family(host: str) -> int:
    return socket.AF_INET6 if ":" in host else socket.AF_INET


def _address_error(exc: OSError, host: str, port: int) -> InputError:
    """The one-line error of a failed bind: a port in use, or a host that is not this machine's."""
    if isinstance(exc, socket.gaierror):
        return InputError("--host", host, f"is not an address or host name this machine resolves ({exc.strerror}); "
                                          "127.0.0.1 serves this machine only, 0.0.0.0 every network interface")
    if exc.errno == errno.EADDRINUSE:
        return InputError("--port", port, f"is in use on {host} (another server listens there): stop it, or give "
                                          "another --port (0 picks a free one)")
    if exc.errno == errno.EADDRNOTAVAIL:
        return InputError("--host", host, "is not an address of this machine: 127.0.0.1 serves this machine only, "
                                          "0.0.0.0 every network interface")
    if exc.errno == errno.EACCES:
        return InputError("--port", port, "needs privileges on this machine (ports below 1024): give a port "
                                          "above 1023 (0 picks a free one)")
    return InputError("--host", f"{host}:{port}", f"cannot serve there: {exc.strerror or exc}")


def check_address(host: str, port: int) -> None:
    """Refuse, before anything is printed or served, a ``host`` this machine cannot bind or a ``port``
    in use there (a test bind with SO_REUSEADDR, as the server binds: on Linux it fails on a port another
    server listens on, but not on one in TIME_WAIT).

    Raises:
        InputError: naming ``--host`` or ``--port``.
    """
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)
        for family, kind, proto, _, addr in infos:
            with socket.socket(family, kind, proto) as s:
                s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
                s.bind(addr)
    except OSError as exc:
        raise _address_error(exc, host, port) from None


#: hosts that bind every interface: the page may then be reached under any of this machine's names and addresses
WILDCARD_HOSTS = ("0.0.0.0", "::", "")


def _this_machine() -> set[str]:
    """This machine's names and addresses as a browser on the network may reach it (host name, its fully qualified
    name, the addresses they resolve to, the address of the default route), best effort: none of it is needed."""
    names = {socket.gethostname(), socket.getfqdn()}
    for name in list(names):
        try:
            names |= {info[4][0] for info in socket.getaddrinfo(name, None)}
        except OSError:
            pass
    try:  # the address other machines reach this one at (a UDP "connection" sends nothing)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.connect(("10.255.255.255", 1))
            names.add(s.getsockname()[0])
    except OSError:
        pass
    return {n for n in names if n}


def check_origin(text: str) -> str:
    """``--origin``'s value as Bokeh's allow-list takes it: ``HOST`` or ``HOST:PORT`` (a scheme such as ``https://``
    and a trailing ``/`` are dropped; ``*`` wildcards within a name or address as Bokeh allows them, ``192.168.1.*``,
    not ``*`` alone).

    Raises:
        InputError: naming ``--origin``, the text and the form allowed.
    """
    import re

    t = re.sub(r"^[a-z]+://", "", str(text).strip().lower()).rstrip("/")
    if t.split(":")[0] == "*":  # any origin: another site's page could open a signed-in user's websocket
        raise InputError("--origin", text, "a host name or address, not every origin ('*'): name the proxy's or "
                                           "this machine's name (wildcards within an address: 192.168.1.*)")
    if not re.fullmatch(r"(\*|[a-z0-9*]([a-z0-9*.-]*[a-z0-9*])?|\[[0-9a-f:]+\])(:(\d{1,5}|\*))?", t):
        raise InputError("--origin", text, "a host name or address the browser reaches the app under, optionally with "
                                           "its port: shop.example.com, 192.168.1.20:5006 (no path)")
    return t


def allowed_origins(host: str, port: int, origins=()) -> list[str]:
    """The origins whose pages may open the app's websocket (Bokeh refuses the others, and the page stays blank):
    the address served, ``localhost`` and ``127.0.0.1`` at ``port``; for a wildcard host (0.0.0.0, ::) also this
    machine's names and addresses (:func:`_this_machine`) at ``port``; and ``origins`` as given (``--origin``: a
    reverse proxy's public name, a name this machine is reached under that it does not know)."""
    got = {f"{host}:{port}", f"localhost:{port}", f"127.0.0.1:{port}"}
    if host.strip() in WILDCARD_HOSTS:
        got |= {(f"[{n}]" if ":" in n else n) + f":{port}" for n in _this_machine()}
    got |= {check_origin(o) for o in origins}
    return sorted(got)


def serve(port: int = DEFAULT_PORT, host: str = DEFAULT_HOST, show: bool = True, threaded: bool = False,
          verbose: bool = False, users: dict[str, str] | None = None, db: str | None = None,
          shops: dict[str, tuple[str, ...]] | None = None, proxy: bool = False, secure_cookies: bool = False,
          origins=()):
    """Serve the app at ``http://host:port/`` (port 0: a free one). Returns (server or server thread, URL);
    with ``threaded`` the server runs in a thread (``.stop()`` ends it), else this blocks until interrupted
    (the URL is printed once the server holds the port, never before). With ``users`` ({name: hash},
    :mod:`millstab.web.auth`) every page needs a login; a host other than 127.0.0.1/localhost/::1
    requires them. ``db``: a shop database (path or URL, created when new) whose campaigns the Update tab
    opens and updates; with ``users``, each user sees only the campaigns of their shops (``shops``: {user:
    shops}; a user not in it: the shop ``default``). ``proxy``: served behind a reverse proxy, so a client's address
    (the login throttle's, :mod:`millstab.web.auth`) is read from the proxy's X-Forwarded-For / X-Real-Ip header, and
    whether it came over HTTPS from its X-Forwarded-Proto / X-Scheme (the login's cookies are then ``Secure``).
    ``secure_cookies``: the login's cookies are ``Secure`` always (an HTTPS proxy that does not say so; a browser
    then keeps them over HTTPS only). ``origins``: more names the browser reaches the page under
    (:func:`allowed_origins`; behind a proxy its public name).

    Raises:
        InputError: a host this machine cannot bind (``--host``), a port in use (``--port``), or a
            non-local host without ``users``.
    """
    from millstab.web.auth import is_local

    check_address(host, port)  # an address that is not this machine's is that, whatever the accounts
    if not users and not is_local(host):
        raise InputError("--host", host, "serves beyond this machine (only 127.0.0.1, localhost and ::1 are local), "
                                         "so it needs accounts: make a users file with `millstab app --add-user NAME "
                                         "--users FILE` and start with --users FILE")
    import panel as pn

    from millstab.web.app import create_app

    if db is not None:  # created or migrated now, and any problem said in one line before the URL
        from millstab.api.shop import DEFAULT_SHOP, open_db

        open_db(db).close()
        if users:
            shops = {u: tuple((shops or {}).get(u) or (DEFAULT_SHOP,)) for u in users}
    where, who = (str(db) if db is not None else None), (shops if users else None)

    def app():  # a plain function: Panel serves a functools.partial as an object (its repr), not a page
        return create_app(db=where, shops=who)

    port = port or free_port(host)
    url = f"http://{host}:{port}/"
    origin = allowed_origins(host, port, origins)
    import secrets

    # Bokeh's session ids and tokens signed with a fresh key per start: unsigned, a client could name its own session
    # id and write its own token, whose payload (the request's cookies, headers, arguments) the page's code reads
    opts = dict(port=port, address=host, websocket_origin=origin, show=show, title="millstab", verbose=verbose,
                use_xheaders=proxy, sign_sessions=True, secret_key=secrets.token_urlsafe(32))
    if users:
        from millstab.web.auth import auth_provider

        # a fresh cookie key per start: logins end with the server
        opts.update(auth_provider=auth_provider(users, secure_cookies=secure_cookies),
                    cookie_secret=secrets.token_urlsafe(32))
    if threaded:
        return pn.serve({"/": app}, threaded=True, **opts), url
    try:
        server = pn.serve({"/": app}, start=False, **opts)  # binds the port here
    except OSError as exc:  # taken since the check
        raise _address_error(exc, host, port) from None
    print(f"millstab app: {url}  (Ctrl+C stops it)", flush=True)
    server.start()
    server.io_loop.start()
    return server, url
