"""Accounts for ``millstab app`` when it serves beyond this machine: a users file of ``name:hash`` lines,
the password hash (scrypt, standard library), and the login that checks it (Panel's basic-auth login
page, with the stored hash compared instead of a plain password).

Rule: the app is *local* when it binds 127.0.0.1, ``localhost`` or ``::1`` exactly; any other address
(``0.0.0.0``, a network address, even another loopback address such as 127.0.0.2) lets other users or
machines reach it, and the app refuses to start there without ``--users FILE``. With a users file every
page needs a login, whatever the address. Passwords are never stored, printed or logged; each browser
session still sees only its own uploads (:class:`millstab.web.state.Session`).

Users file (made 0600, readable by its owner only, by ``millstab app --add-user NAME --users FILE
[--shop SHOP ...]``; keep it private)::

    # millstab app users: name:scrypt$N$r$p$salt$hash[:shop,shop]
    anna:scrypt$16384$8$1$3q2+7w...$Jm9v...:acme
    carl:scrypt$16384$8$1$Zm9v...$YmFy...:acme,bolt

**Shops** (with ``millstab app --db``): an account belongs to the shops listed after its hash (none listed:
the shop ``default``, the shop of campaigns made on the command line); it sees and writes only the campaigns
of its shops (the rule is enforced by :class:`millstab.api.shop.ShopView`, which the page uses for every
read and write).

**Throttling**: failed logins within :data:`WINDOW_S` seconds are counted per user name from one address, per
address and per user name (:data:`FAILURE_LIMITS`: 5, 20, 50); at its limit a key is refused for
:data:`LOCKOUT_S` seconds with a message saying so, without hashing the password (:class:`LoginThrottle`, in
memory: a restart forgets it). A name is locked for everyone only after more failures than one address may make,
so one guesser cannot lock a known user out (it locks only itself), and a guesser cycling through names from one
address stops at 20. Behind a reverse proxy every client has the proxy's address: serve with ``proxy=True``
(``millstab app --behind-proxy``) to take the client's address from the proxy's X-Forwarded-For / X-Real-Ip
header (only behind a proxy that sets it: without one a client could write its own). The scrypt check runs in a
worker thread, so a login flood does not stall the other sessions.

**Sessions**: a logout ends its login on the server (:data:`REVOKED`: a copy of its cookie opens nothing after it);
the login pages' cookies are ``SameSite=Lax`` and, over HTTPS (or with ``secure_cookies``), ``Secure``; the login
form carries Tornado's ``_xsrf`` double-submit token, checked before the password (:func:`auth_provider`).
"""

from __future__ import annotations

import base64
import hashlib
import hmac
import re
import secrets
import threading
import time
from pathlib import Path

from millstab.errors import InputError

#: the addresses that serve this machine only
LOCAL_HOSTS = ("127.0.0.1", "localhost", "::1")
#: scrypt cost (2^14, r 8, p 1: ~50 ms and 16 MB per check, the work factor Python's docs and OWASP name)
SCRYPT_N, SCRYPT_R, SCRYPT_P = 2**14, 8, 1
_NAME = re.compile(r"[A-Za-z0-9_.@+-]{1,64}")
MIN_PASSWORD = 8
#: login throttling: failures within WINDOW_S seconds that lock a key out for LOCKOUT_S seconds, per kind of key: a
#: user name from one address ("pair"), an address ("addr", whatever the names), a user name from any address
#: ("user": above what one address may make, so a single guesser cannot lock a known user out for everyone)
FAILURE_LIMITS = {"pair": 5, "addr": 20, "user": 50}
WINDOW_S, LOCKOUT_S = 300.0, 300.0
#: the failures that lock one user name out at one address (the limit a user meets first)
MAX_FAILURES = FAILURE_LIMITS["pair"]


def is_local(host: str) -> bool:
    """Whether binding ``host`` serves this machine only (see the module's rule)."""
    return host.strip().lower() in LOCAL_HOSTS


def _b64(b: bytes) -> str:
    return base64.b64encode(b).decode("ascii")


def hash_password(password: str, salt: bytes | None = None) -> str:
    """``scrypt$N$r$p$salt$hash`` of ``password`` (a fresh 16-byte salt unless given)."""
    salt = secrets.token_bytes(16) if salt is None else salt
    digest = hashlib.scrypt(password.encode("utf-8"), salt=salt, n=SCRYPT_N, r=SCRYPT_R, p=SCRYPT_P, dklen=32)
    return f"scrypt${SCRYPT_N}${SCRYPT_R}${SCRYPT_P}${_b64(salt)}${_b64(digest)}"


def check_password(password: str, stored: str) -> bool:
    """Whether ``password`` matches ``stored`` (:func:`hash_password`'s form), in constant time."""
    try:
        kind, n, r, p, salt, digest = stored.split("$")
        if kind != "scrypt":
            return False
        want = base64.b64decode(digest, validate=True)
        got = hashlib.scrypt(password.encode("utf-8"), salt=base64.b64decode(salt, validate=True), n=int(n), r=int(r),
                             p=int(p), dklen=len(want), maxmem=2**26)
    except (ValueError, TypeError):
        return False
    return hmac.compare_digest(got, want)


def check_name(name: str) -> str:
    if not _NAME.fullmatch(name or ""):
        raise InputError("--add-user", name, "a user name of 1..64 letters, digits or _ . @ + -")
    return name


def check_shops(shops) -> tuple[str, ...]:
    """Shop names (the same characters as user names), in order, each once."""
    from millstab.api.shop import check_shop

    return tuple(dict.fromkeys(check_shop(x) for x in shops))


_HASH = re.compile(r"scrypt\$\d+\$\d+\$\d+\$[A-Za-z0-9+/=]+\$[A-Za-z0-9+/=]+")


def parse_accounts(text: str, where: str = "--users", require: bool = True) -> dict[str, tuple[str, tuple[str, ...]]]:
    """{name: (hash, shops)} of a users file's text (``name:hash[:shop,shop]`` lines; no shop listed: the
    shop ``default``); blank and ``#`` lines are skipped.

    Raises:
        InputError: a line that is not ``name:scrypt$...[:shops]`` (a plain password is refused: it would be
            stored in clear), or (``require``) no user at all.
    """
    from millstab.api.shop import DEFAULT_SHOP

    users: dict[str, tuple[str, tuple[str, ...]]] = {}
    for no, line in enumerate(text.splitlines(), start=1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        name, _, rest = s.partition(":")
        stored, _, shops = rest.partition(":")  # a scrypt hash has no ':'
        try:
            if not _NAME.fullmatch(name) or not _HASH.fullmatch(stored):
                raise InputError("", "", "")
            listed = check_shops(x for x in shops.split(",") if x.strip()) if shops.strip() else (DEFAULT_SHOP,)
        except InputError:
            raise InputError(f"{where} line {no}", f"{name}:…", "expected name:scrypt$...[:shop,shop] as written "
                                                                "by `millstab app --add-user NAME --users FILE` "
                                                                "(never a plain password)") from None
        users[name] = (stored, listed)
    if require and not users:
        raise InputError(where, "no users", "add one with `millstab app --add-user NAME --users FILE`")
    return users


def parse_users(text: str, where: str = "--users", require: bool = True) -> dict[str, str]:
    """{name: hash} of a users file's text (:func:`parse_accounts` without the shops)."""
    return {n: h for n, (h, _) in parse_accounts(text, where, require).items()}


def read_accounts(path: str | Path) -> dict[str, tuple[str, tuple[str, ...]]]:
    """{name: (hash, shops)} of the users file at ``path`` (:func:`parse_accounts`)."""
    from millstab.io.text import read_text

    p = Path(path).expanduser()
    if not p.is_file():
        raise InputError("--users", str(path), "file does not exist: make it with `millstab app --add-user NAME "
                                               "--users FILE`")
    return parse_accounts(read_text(p, "--users", "users file"), f"--users {p.name}")


def read_users(path: str | Path) -> dict[str, str]:
    """The users of the file at ``path``: {name: hash}."""
    return {n: h for n, (h, _) in read_accounts(path).items()}


def read_shops(path: str | Path) -> dict[str, tuple[str, ...]]:
    """The shops of each user of the file at ``path``: {name: shops}."""
    return {n: s for n, (_, s) in read_accounts(path).items()}


def add_user(path: str | Path, name: str, password: str, shops=None) -> Path:
    """Add ``name`` (or replace its password) in the users file at ``path``, made if missing; ``shops``: the
    shops it belongs to (default: those it had, else none listed, i.e. the shop ``default``)."""
    from millstab.io.results import atomic_write_text
    from millstab.io.text import read_text

    check_name(name)
    shops = check_shops(shops) if shops else None
    if len(password) < MIN_PASSWORD:
        raise InputError("password", f"{len(password)} characters", f"at least {MIN_PASSWORD} characters")
    p = Path(path).expanduser()
    had = None
    if p.is_file():
        lines = read_text(p, "--users", "users file").splitlines()
        # never rewrite a file that is not one
        had = parse_accounts("\n".join(lines), f"--users {p.name}", require=False).get(name)
    else:
        lines = ["# millstab app users: name:scrypt$N$r$p$salt$hash[:shop,shop] (made by millstab app --add-user; "
                 "keep private)"]
    if shops is None and had is not None and lines and any(ln.strip().startswith(f"{name}:") and ln.count(":") >= 2
                                                             for ln in lines):
        shops = had[1]
    kept = [ln for ln in lines if ln.strip().partition(":")[0] != name]
    line = f"{name}:{hash_password(password)}" + (f":{','.join(shops)}" if shops else "")
    # the hashes are secret: owner-only (0600), also when an older file was readable by others
    return atomic_write_text(p, "\n".join(kept + [line]) + "\n", mode=0o600)


class LoginThrottle:
    """Failed logins per key (``("pair", name, ip)``, ``("addr", ip)``, ``("user", name)``: the first item is the
    key's kind, whose limit ``limits`` gives, :data:`FAILURE_LIMITS` by default), in memory: :meth:`refused` says
    how many seconds a key is still locked out (0: not), :meth:`begin` counts an attempt as a failure before the
    password is checked (so parallel attempts cannot slip past the limit), :meth:`success` forgets a key's
    failures. Thread-safe; ``clock``: seconds (``time.monotonic``)."""

    def __init__(self, limits: dict[str, int] | None = None, window_s: float = WINDOW_S, lockout_s: float = LOCKOUT_S,
                 clock=time.monotonic, max_keys: int = 100_000):
        self.limits = dict(FAILURE_LIMITS if limits is None else limits)
        self.window_s, self.lockout_s = window_s, lockout_s
        self.clock, self.max_keys = clock, max_keys
        self._fails: dict[tuple, list[float]] = {}
        self._until: dict[tuple, float] = {}
        self._lock = threading.Lock()

    def refused(self, *keys) -> float:
        """Seconds left of the longest lockout among ``keys`` (0.0: none is locked out)."""
        now = self.clock()
        with self._lock:
            return max([0.0] + [self._until.get(k, now) - now for k in keys])

    def begin(self, *keys) -> None:
        """Count an attempt for ``keys`` as a failure (undone by :meth:`success`); lock out a key at the limit."""
        now = self.clock()
        with self._lock:
            if len(self._fails) > self.max_keys:  # keep memory bounded under a flood of names or addresses
                self._prune(now)
            for k in keys:
                fails = [t for t in self._fails.get(k, ()) if now - t < self.window_s] + [now]
                self._fails[k] = fails
                if len(fails) >= self.limits[k[0]]:
                    self._until[k] = now + self.lockout_s

    def success(self, *keys) -> None:
        """Forget the failures of ``keys`` (a correct password)."""
        with self._lock:
            for k in keys:
                self._fails.pop(k, None)
                self._until.pop(k, None)

    def _prune(self, now: float) -> None:
        self._fails = {k: v for k, v in self._fails.items() if v and now - v[-1] < self.window_s}
        self._until = {k: t for k, t in self._until.items() if t > now}
        if len(self._fails) > self.max_keys:  # still too many: the oldest go
            keep = sorted(self._fails, key=lambda k: self._fails[k][-1])[-self.max_keys // 2:]
            self._fails = {k: self._fails[k] for k in keep}


def refused_message(seconds: float) -> str:
    """The login page's message for a locked-out name or address."""
    minutes = max(1, int(-(-seconds // 60)))
    n = FAILURE_LIMITS
    return (f"Too many failed logins ({n['pair']} for this user name from this address, {n['addr']} from this "
            f"address or {n['user']} for this user name within {WINDOW_S / 60:g} min): try again in {minutes} min")


class Revocations:
    """The logins ended by a logout, per process (a restart makes a new cookie key, which ends every login anyway):
    :meth:`revoke` records a signed ``user`` cookie, :meth:`revoked` says whether a cookie is one. Kept by its SHA-256
    until it would have expired anyway (``max_age_s`` after its logout: it was issued before); above ``max_keys``
    live records a logout instead ends every login of its user issued up to the logged-out one (never fewer than
    asked, in bounded memory). Thread-safe; ``clock``: seconds since the epoch (``time.time``, as the cookie's
    own timestamp)."""

    def __init__(self, max_keys: int = 100_000, clock=time.time):
        self.max_keys, self.clock = max_keys, clock
        self._cookies: dict[bytes, float] = {}  # digest of a revoked cookie: when it expires anyway [s]
        self._before: dict[str, int] = {}  # user: their logins issued at or before this second are revoked
        self._lock = threading.Lock()

    @staticmethod
    def _digest(cookie: str) -> bytes:
        return hashlib.sha256(cookie.encode("utf-8", "surrogateescape")).digest()

    def revoke(self, cookie: str, user: str, issued: int, max_age_s: float) -> None:
        """End the login of ``cookie`` (a valid signed ``user`` cookie of ``user``, issued at second ``issued``)."""
        now = self.clock()
        with self._lock:
            if len(self._cookies) >= self.max_keys:
                self._cookies = {k: t for k, t in self._cookies.items() if t > now}
            if len(self._cookies) < self.max_keys:
                self._cookies[self._digest(cookie)] = now + max_age_s
            else:
                self._before[user] = max(self._before.get(user, issued), issued)

    def revoked(self, cookie: str, user: str, issued: int) -> bool:
        """Whether the login of ``cookie`` (``user``'s, issued at second ``issued``) was ended by a logout."""
        with self._lock:
            return self._digest(cookie) in self._cookies or issued <= self._before.get(user, -1)


#: the logins ended by a logout in this process (the auth provider's user check and :func:`signed_in_user` ask it)
REVOKED = Revocations()
#: the login's cookies go with requests from this site and with links followed from another (a bookmark, a mail);
#: another site's form post, frame or script gets none (Strict would also drop them on a link from another site)
SAME_SITE = "Lax"


def _issued(cookie: str) -> int:
    """The second a signed cookie was made (Tornado's version-2 format ``2|1:0|10:TIME|...``; 0 if another)."""
    parts = cookie.split("|")
    try:
        return int(parts[2].split(":", 1)[1]) if parts[0] == "2" else 0
    except (IndexError, ValueError):
        return 0


def login_of(cookie: str | None) -> tuple[str, int] | None:
    """(user, second issued) of a signed ``user`` cookie that is valid now: signed with this server's key, within the
    login's lifetime (Panel's ``oauth_expiry`` days) and not ended by a logout (:data:`REVOKED`); else None."""
    from panel.config import config
    from tornado.web import decode_signed_value

    if not cookie or config.cookie_secret is None:
        return None
    got = decode_signed_value(config.cookie_secret, "user", cookie, max_age_days=config.oauth_expiry)
    if got is None:
        return None
    user, issued = got.decode("utf-8"), _issued(cookie)
    return None if REVOKED.revoked(cookie, user, issued) else (user, issued)


def auth_provider(users: dict[str, str], throttle: LoginThrottle | None = None, secure_cookies: bool = False):
    """A Panel/Bokeh auth provider: Panel's login and logout pages, the password checked against ``users``'
    hashes, failed logins throttled by ``throttle`` (a fresh :class:`LoginThrottle` by default). The login form
    carries a double-submit token (Tornado's ``_xsrf``: a post without the one of its cookie is refused, so another
    site cannot sign a visitor into its account); its cookies are ``SameSite=Lax`` (:data:`SAME_SITE`), ``HttpOnly``
    and ``Secure`` on a request that came over HTTPS (as the proxy says with ``X-Forwarded-Proto`` when served with
    ``proxy``) or always with ``secure_cookies``; a logout ends its login on the server (:data:`REVOKED`), so a copy
    of the cookie opens nothing after it. Imports Panel."""
    import asyncio
    import urllib.parse

    from panel.auth import BasicAuthProvider, BasicLoginHandler, LogoutHandler, _validate_next_url
    from panel.config import config
    from panel.io.resources import CDN_DIST, _env
    from panel.io.state import state
    from tornado.web import HTTPError

    throttle = throttle if throttle is not None else LoginThrottle()

    class CookieRules:
        """Every cookie these pages set (the login's, the form's token, ``next_url``, a cleared one): SameSite, and
        Secure when the page came over HTTPS or ``secure_cookies``."""

        def set_cookie(self, name, value, *args, **kwargs):
            kwargs["samesite"] = SAME_SITE
            if secure_cookies or self.request.protocol == "https":
                kwargs["secure"] = True
            return super().set_cookie(name, value, *args, **kwargs)

    class HashedLogin(CookieRules, BasicLoginHandler):
        def get(self):
            # Panel's page with the form's token (the page Panel's own handler writes, plus the _xsrf field)
            next_url = _validate_next_url(self.get_argument("next", state.base_url))
            if next_url:
                self.set_cookie("next_url", next_url)
            self.write(self._form.render(login_endpoint=self._login_endpoint,
                                         errormessage=self.get_argument("error", ""), PANEL_CDN=CDN_DIST,
                                         xsrf_form_html=self.xsrf_form_html()))

        def _validate(self, username, password):
            stored = users.get(username)
            if stored is None:
                check_password(password, _DUMMY)  # the same time for an unknown name
                return False
            return check_password(password, stored)

        async def post(self):
            try:
                self.check_xsrf_cookie()  # before anything else: a forged post costs no hashing and counts nothing
            except HTTPError:
                self._fail("The login form was not this page's, or has expired: log in again")
                return
            username = self.get_argument("username", "")
            password = self.get_argument("password", "")
            ip = self.request.remote_ip  # the proxy's header's client address with proxy=True (tornado's xheaders)
            keys = (("pair", username, ip), ("addr", ip), ("user", username))
            left = throttle.refused(*keys)
            if left > 0:  # refused before any hashing: a flood costs no scrypt
                self._fail(refused_message(left))
                return
            throttle.begin(*keys)
            # scrypt in a worker thread (it releases the GIL): the server's thread keeps serving the other sessions
            ok = await asyncio.get_running_loop().run_in_executor(None, self._validate, username, password)
            if ok:
                throttle.success(*keys)
                self.set_current_user(username)
                self.redirect(_validate_next_url(self.get_cookie("next_url", state.base_url)))
            else:
                self._fail("Invalid username or password!")

        def _fail(self, message: str):
            self.redirect(self.request.path + "?error=" + urllib.parse.quote_plus(message))

    class RevokingLogout(CookieRules, LogoutHandler):
        def get(self):
            cookie = self.get_cookie("user")
            got = login_of(cookie)
            if got is not None:  # only a valid login is recorded: made-up cookies cannot fill the record
                REVOKED.revoke(cookie, got[0], got[1], config.oauth_expiry * 86400.0)
            super().get()

    class HashedAuth(BasicAuthProvider):
        @property
        def login_handler(self):
            HashedLogin._login_endpoint = self._login_endpoint
            HashedLogin._form = _login_form(self._login_template, _env)
            return HashedLogin

        @property
        def logout_handler(self):
            RevokingLogout._logout_template = _own_page(self._logout_template, _env)
            RevokingLogout._login_endpoint = self._login_endpoint
            return RevokingLogout

        @property
        def get_user(self):
            panels = super().get_user

            def get_user(handler):  # every page, websocket and static file: a logged-out cookie is no login
                cookie = handler.get_cookie("user")
                if cookie and login_of(cookie) is None:
                    return None
                return panels(handler)

            return get_user

    return HashedAuth()


def _login_form(template, env):
    """Panel's login page ``template`` with the form's ``_xsrf`` field (rendered as ``xsrf_form_html``).

    Raises:
        RuntimeError: a Panel whose login page has no ``<form ...>`` to put it in (the login would be refused)."""
    import re as _re

    source = _own_source(env.loader.get_source(env, template.name)[0]) if template.name else None
    opened = _re.search(r"<form\b[^>]*>", source or "")
    if opened is None:
        raise RuntimeError("millstab app: Panel's login page has no <form>: cannot add its _xsrf field")
    return env.from_string(source[:opened.end()] + "{{ xsrf_form_html|safe }}" + source[opened.end():])


#: what the login and logout pages show in place of Panel's logo
PAGE_HEADING = "millstab: milling stability"


def _own_source(source: str) -> str:
    """Panel's login or logout page ``source`` as millstab's: the title says millstab (not "Panel App"), and the
    heading is text in place of Panel's logo, an image fetched from Panel's CDN on the internet: on a shop network
    without internet it was a broken image, and elsewhere every login told that CDN the page was used."""
    import re as _re

    source = source.replace("Panel App |", "millstab |")
    return _re.sub(r"<img\b[^>]*\bid=\"logo\"[^>]*>", f'<span id="logo">{PAGE_HEADING}</span>', source)


def _own_page(template, env):
    """Panel's logout page ``template`` as millstab's (:func:`_own_source`); a template without a file (Panel's
    own, always with one) is kept."""
    if not template.name:
        return template
    return env.from_string(_own_source(env.loader.get_source(env, template.name)[0]))


def signed_in_user() -> str | None:
    """The account of the page being built (in ``pn.serve``'s page function): the name in the login's signed
    ``user`` cookie, or None. Not ``pn.state.user``: that answers "guest" for any request that carries an
    ``is_guest`` cookie, which a browser writes itself, so a signed-in user became the account ``guest`` (and
    saw its shops' campaigns) by adding ``is_guest=1`` to their cookies. Imports Panel."""
    from panel.io.state import state

    # the age limit of Panel's own check (get_user), and no login ended by a logout (login_of)
    got = login_of((state.cookies or {}).get("user"))
    return None if got is None else got[0]


_DUMMY = hash_password("not a password", b"millstab-dummy!!")
