"""``millstab app``: serve the browser interface (needs the ``millstab[app]`` extra: Panel)."""

from __future__ import annotations

import typer

from millstab.cli.app import app
from millstab.errors import InputError


@app.command("app")
def app_cmd(
    port: int = typer.Option(5006, "--port", help="TCP port (0: a free one)."),
    host: str = typer.Option("127.0.0.1", "--host", help="Address to bind; the default serves this machine only "
                                                        "(0.0.0.0 serves the network: anyone who reaches it can use it)."),
    no_browser: bool = typer.Option(False, "--no-browser", help="Do not open a browser tab."),
) -> None:
    """Serve the stability tools as a web page (tool and cut, lobes, identify, update, downloads); prints the URL."""
    if not 0 <= port <= 65535:
        raise InputError("--port", port, "must be a TCP port 0..65535")
    try:
        import panel  # noqa: F401
    except ImportError:
        raise InputError("millstab app", "panel not installed", "install the app extra: pip install 'millstab[app]'") from None
    from millstab.web import serve

    serve(port=port, host=host, show=not no_browser)
