"""Long work off the page's thread: a worker thread runs the service function, the page polls its
progress every 250 ms (a periodic callback in the session, so widgets are only touched from the
session's own event loop), and a cancel button stops it through :class:`millstab.api.CancelToken`."""

from __future__ import annotations

import threading
import time
import traceback
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Callable

import panel as pn

from millstab import api
from millstab.errors import InputError
from millstab.web.common import TextBox

#: worker threads shared by all sessions of one server (the machine's cores are the limit anyway)
EXECUTOR = ThreadPoolExecutor(max_workers=2, thread_name_prefix="millstab-job")
#: how often the page shows progress [ms]: each update costs the server's thread (and the GIL the worker
#: needs) tens of ms on a loaded machine, so not more often
POLL_MS = 250


def collected(work: Callable[[api.Progress], Any], progress: api.Progress) -> tuple[Any, list[str]]:
    """(``work(progress)``, the texts of the millstab warnings it issued, each once, in order): a job's result and
    notes. Collected per thread (:mod:`millstab.warnlog`), so another session's job adds nothing; once each, as a
    job whose parts warn alike (a map and a recommendation from one zero-order posterior) says it once."""
    with api.collect_warnings() as caught:
        result = work(progress)
    return result, list(dict.fromkeys(str(w.message) for w in caught))


class JobBar(pn.viewable.Viewer):
    """A run button, a cancel button, a progress bar and a status line for one kind of long work.

    ``start(work, done)``: ``work(progress)`` runs in a worker thread and returns a result; ``done(result,
    warnings)`` then runs in the session. An :class:`InputError` or any failure is shown in the status
    line (the page keeps running); a cancel shows "cancelled".
    """

    def __init__(self, label: str, css: str):
        super().__init__()
        self.run = pn.widgets.Button(label=label, color="primary", css_classes=[f"{css}-run"], width=160)
        self.cancel = pn.widgets.Button(label="Cancel", color="warning", disabled=True,
                                        css_classes=[f"{css}-cancel"], width=90)
        self.bar = pn.indicators.Progress(value=0, max=100, active=False, width=260, css_classes=[f"{css}-bar"],
                                          visible=False)  # active=False: no animated stripes
        self.status = TextBox(f"{css}-status", width=520, height=24)
        self._token: api.CancelToken | None = None
        self._future = None
        self._cb = None
        self._lock = threading.Lock()
        self._report: tuple[str, int, int | None] = ("", 0, None)
        self._t0 = 0.0
        self.cancel.on_click(lambda e: self._cancel())

    def __panel__(self):
        return pn.Column(pn.Row(self.run, self.cancel, self.bar), self.status.view())

    def _cancel(self) -> None:
        """Ask the job to stop; said at once (it stops at its next cancel point: within an engine chunk, ≲ 1 s)."""
        if self._token is not None and self.busy:
            self._token.cancel()
            self.status.text = "cancelling …"

    @property
    def busy(self) -> bool:
        return self._future is not None and not self._future.done()

    def start(self, work: Callable[[api.Progress], Any], done: Callable[[Any, list[str]], None]) -> None:
        if self.busy:
            return
        self._token = api.CancelToken()
        self._report = ("starting", 0, None)
        self._t0 = time.perf_counter()

        def progress(stage: str, n: int, total: int | None) -> None:
            with self._lock:
                self._report = (stage, n, total)

        token = self._token
        watched = token.watch(progress)

        def run():
            # the cancel points of the engine calls (millstab.progress) see this job's token, on this worker thread
            # only: an update's first stage and a map from an sdm posterior report no progress for minutes
            with token.checked():
                token.check()  # cancelled while it waited for a worker thread (two, shared by every session)
                return collected(work, watched)

        self._future = EXECUTOR.submit(run)
        self.run.disabled, self.cancel.disabled = True, False
        # the bar appears once a stage reports its total: an indeterminate bar's animation costs the browser
        # CPU that the work needs on a small machine; the status line shows the iteration meanwhile
        self.bar.visible, self.bar.value = False, 0
        self.status.text = "running …"
        self._done = done
        self._cb = pn.state.add_periodic_callback(self._poll, period=POLL_MS)

    def _poll(self) -> None:
        fut = self._future
        with self._lock:
            stage, n, total = self._report
        if total:
            value = int(100 * min(n, total) / total)
            if self.bar.value != value:
                self.bar.value = value
            if not self.bar.visible:
                self.bar.visible = True
        elif self.bar.visible:
            self.bar.visible = False
        word = "cancelling" if self._token is not None and self._token.cancelled else "running"
        # the stage is text, not markup: it may quote a name or a value that came from an upload
        self.status.text = (f"{word}: {_esc(stage)} ({n}{f'/{total}' if total else ''}) "
                            f"{time.perf_counter() - self._t0:.1f} s")
        if fut is None or not fut.done():
            return
        self._cb.stop()
        self._cb = None
        self.run.disabled, self.cancel.disabled = False, True
        self.bar.visible = False
        elapsed = time.perf_counter() - self._t0
        try:
            result, caught = fut.result()
            # the result is shown first and "done" said last: the browser receives the two updates in this order,
            # so a reader (or a test) that waits for "done" finds the result already on the page
            self._done(result, caught)
        except api.Cancelled:
            self.status.text = '<span class="ms-error">cancelled</span>'
        except InputError as exc:
            self.status.text = f'<span class="ms-error">{_esc(str(exc))}</span>'
        except Exception as exc:  # a bug must not take the page down: show it, keep the page
            traceback.print_exc()
            self.status.text = f'<span class="ms-error">failed: {_esc(type(exc).__name__)}: {_esc(str(exc))}</span>'
        else:
            self.status.text = f'<span class="ms-done">done in {elapsed:.2f} s</span>'


def _esc(s: str) -> str:
    import html

    return html.escape(s)
