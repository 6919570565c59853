"""``millstab app``: the stability tools in a browser (Panel + Bokeh), served by the package itself.

The page calls the service layer (:mod:`millstab.api`) only: the same validators, numbers and files as
the command line. Each browser tab has its own session state; long work runs in worker threads with
progress and cancel. Importing :mod:`millstab.web.app` imports Panel (the ``millstab[app]`` extra); this
module does not.
"""

from __future__ import annotations

import socket

#: the address the app binds to unless told otherwise: this machine only
DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 5006


def free_port(host: str = DEFAULT_HOST) -> int:
    """A TCP port free on ``host`` now."""
    with socket.socket() as s:
        s.bind((host, 0))
        return s.getsockname()[1]


def serve(port: int = DEFAULT_PORT, host: str = DEFAULT_HOST, show: bool = True, threaded: bool = False,
          verbose: bool = False):
    """Serve the app at ``http://host:port/`` (port 0: a free one). Returns (server or server thread, URL);
    with ``threaded`` the server runs in a thread (``.stop()`` ends it), else this blocks until interrupted
    (the URL is printed first)."""
    import panel as pn

    from millstab.web.app import create_app

    port = port or free_port(host)
    url = f"http://{host}:{port}/"
    origin = sorted({f"{host}:{port}", f"localhost:{port}", f"127.0.0.1:{port}"})
    if not threaded:
        print(f"millstab app: {url}  (Ctrl+C stops it)", flush=True)
    server = pn.serve({"/": create_app}, port=port, address=host, websocket_origin=origin, show=show,
                      threaded=threaded, title="millstab", verbose=verbose)
    return server, url
