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


def auth_provider(users: dict[str, str], throttle: LoginThrottle | None = None):
    """A Panel/Bokeh auth provider: Panel's login and logout pages, the password checked against ``users``'
    hashes, failed logins throttled by ``throttle`` (a fresh :class:`LoginThrottle` by default). Imports Panel."""
    import asyncio
    import urllib.parse

    from panel.auth import BasicAuthProvider, BasicLoginHandler, _validate_next_url
    from panel.io.state import state

    throttle = throttle if throttle is not None else LoginThrottle()

    class HashedLogin(BasicLoginHandler):
        def _validate(self, username, password):
            stored = users.get(username)
            if stored is None:
                check_password(password, _DUMMY)  # the same time for an unknown name
                return False
            return check_password(password, stored)

        async def post(self):
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

    class HashedAuth(BasicAuthProvider):
        @property
        def login_handler(self):
            HashedLogin._login_endpoint = self._login_endpoint
            HashedLogin._login_template = self._login_template
            return HashedLogin

    return HashedAuth()


def signed_in_user() -> str | None:
    """The account of the page being built (in ``pn.serve``'s page function): the name in the login's signed
    ``user`` cookie, or None. Not ``pn.state.user``: that answers "guest" for any request that carries an
    ``is_guest`` cookie, which a browser writes itself, so a signed-in user became the account ``guest`` (and
    saw its shops' campaigns) by adding ``is_guest=1`` to their cookies. Imports Panel."""
    from panel.config import config
    from panel.io.state import state
    from tornado.web import decode_signed_value

    cookie = (state.cookies or {}).get("user")
    if not cookie or config.cookie_secret is None:
        return None
    # the age limit of Panel's own check (get_user): a cookie older than the login's lifetime is no login
    got = decode_signed_value(config.cookie_secret, "user", cookie, max_age_days=config.oauth_expiry)
    return None if got is None else got.decode("utf-8")


_DUMMY = hash_password("not a password", b"millstab-dummy!!")
