"""Driving the app from Playwright (the browser tests and ``benchmarks/bench_app.py``): serve it on a
free local port, find widgets by their CSS classes, read the SLD's data out of the page's Bokeh
document, and time a redraw from the key press to the plot's next frame."""

from __future__ import annotations

import time
import urllib.request
from contextlib import contextmanager
from pathlib import Path

#: Debian's chromium (Playwright's own browser download does not work on these machines)
CHROMIUM = Path("/usr/bin/chromium")
LAUNCH = {"executable_path": str(CHROMIUM), "args": ["--no-sandbox"]}


@contextmanager
def running_app(timeout: float = 120.0, host: str = "127.0.0.1", users: dict[str, str] | None = None,
                db: str | None = None, shops: dict[str, tuple[str, ...]] | None = None, proxy: bool = False,
                secure_cookies: bool = False, origins=()):
    """Serve the app on ``host`` (127.0.0.1) and a free port in a thread, with a login for ``users``
    ({name: hash}) if given, the shop database ``db`` and the users' ``shops`` (``proxy``: client addresses from
    X-Forwarded-For, as behind a reverse proxy; ``secure_cookies``: login cookies always Secure; ``origins``: more
    names the page may be reached under, ``serve``'s); yields the URL;
    stops the server after."""
    from millstab.web import serve

    thread, url = serve(port=0, host=host, threaded=True, show=False, users=users, db=db, shops=shops, proxy=proxy,
                         secure_cookies=secure_cookies, origins=origins)
    t_end = time.monotonic() + timeout
    while True:
        try:
            # one request may wait for the rest of the time: each GET builds a new session, so short timeouts
            # on a loaded machine only pile up sessions that never finish (seen at load 20: 60 s was not enough)
            left = max(5.0, t_end - time.monotonic())
            urllib.request.urlopen(url, timeout=left).read(100)  # noqa: S310 (our own local server)
            break
        except OSError:
            if time.monotonic() > t_end:
                thread.stop()
                raise
            time.sleep(0.2)
    try:
        yield url
    finally:
        thread.stop()


def open_app(page, url: str, timeout_ms: float = 90_000) -> None:
    """Load the page and wait until the form has validated its first config."""
    page.goto(url)
    page.locator(".tool-status").filter(has_text="valid").wait_for(timeout=timeout_ms)


def tab(page, title: str) -> None:
    page.locator(".bk-tab", has_text=title).first.click()


def field(page, key: str):
    """The <input> of the form field for the config key ``key`` (``cutting.kt``, ``structure.x[0].k``)."""
    return page.locator(f".f-{css_name(key)} input").first


def css_name(key: str) -> str:
    return "".join(c if c.isalnum() else "-" for c in key)


def text(page, css: str) -> str:
    """The text shown by the first element with CSS class ``css`` (Panel panes draw into a shadow root)."""
    return page.locator(f".{css}").first.evaluate(
        """e => [...(e.shadowRoot || e).childNodes].filter(n => !['STYLE', 'LINK'].includes(n.nodeName))
                 .map(n => n.textContent).join('')""").strip()


def set_field(page, key: str, value: str) -> None:
    f = field(page, key)
    f.fill(value)
    f.press("Enter")


def set_samples(page, samples) -> None:
    """Type ``samples`` in the Update tab's samples field and apply it (Enter)."""
    box = page.locator(".update-samples input").first
    box.fill(str(samples))
    box.press("Enter")


def upload(page, css: str, path) -> None:
    """Give a file to the drop zone with CSS class ``css``."""
    page.locator(f".{css} input[type=file]").first.set_input_files(str(path))


_SOURCE = """(name) => { const d = Bokeh.documents[0]; const s = d.get_model_by_name(name);
  if (s == null) return null; const get = (k) => (s.data instanceof Map ? s.data.get(k) : s.data[k]);
  const out = {}; for (const k of ['rpm', 'blim_mm', 'lobe', 'chatter_hz']) { const v = get(k);
    out[k] = v == null ? null : Array.from(v); }
  return out; }"""


def source_data(page, name: str = "sld_source") -> dict | None:
    """The columns of the named ColumnDataSource as the browser holds them."""
    return page.evaluate(_SOURCE, name)


_ARM = """(name) => { window.__t0 = null; window.__t1 = null; window.__n = 0;
  if (!window.__armed) { window.__armed = true;
    document.addEventListener('keydown', (e) => { if (e.key === 'Enter') window.__t0 = performance.now(); }, true); }
  const s = Bokeh.documents[0].get_model_by_name(name);
  if (!s.__timed) { s.__timed = true;
    s.connect(s.properties.data.change, () => { window.__n += 1; window.__tc = performance.now();
      requestAnimationFrame(() => requestAnimationFrame(() => { window.__t1 = performance.now(); })); }); } }"""


def timed_edit(page, key: str, value: str, source: str = "sld_source", timeout: float = 30.0) -> float:
    """Edit a form field and return the time [ms] from the Enter key to the second animation frame after
    the SLD's data source changed in the browser (server compute + transfer + render)."""
    page.evaluate(_ARM, source)
    set_field(page, key, value)
    t_end = time.monotonic() + timeout
    while True:
        t0, t1, tc = page.evaluate("() => [window.__t0, window.__t1, window.__tc]")
        if t0 is not None and t1 is not None:
            print(f"[timed_edit] data changed after {tc - t0:.0f} ms, painted {t1 - tc:.0f} ms later")
            return float(t1 - t0)
        if time.monotonic() > t_end:
            raise TimeoutError(f"the SLD did not change within {timeout} s after {key} = {value}")
        time.sleep(0.01)
