"""``erosim view RUN``: open a run folder and show it — a self-contained HTML file, or the local server.

Both read the run with :func:`erosim.io.results.open_run` (one sentence for a folder that is not a
run) and build the page with :mod:`erosim.view.page`; the server is :mod:`erosim.view.server`.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

from erosim.core.atomic import write_text
from erosim.core.errors import InputError
from erosim.io.results import open_run
from erosim.view import page, server


def write_html(run: str | os.PathLike, out: str | os.PathLike, *, max_side: int = page.MAX_SIDE) -> dict:
    """One HTML file holding the view of ``run`` (plotly.js and the data inside); returns path and size."""
    o = Path(out)
    if o.is_dir():
        raise InputError(f"'{o}' is a folder; give the HTML file to write, e.g. --html view.html.")
    p = page.payload(open_run(run), max_side=max_side)
    write_text(o, page.html(p, inline=True))
    return {"path": str(o), "bytes": o.stat().st_size}


def start(run: str | os.PathLike, port: int = 0, *, max_side: int = page.MAX_SIDE):
    """Build the view of ``run`` and start its server on 127.0.0.1 in a thread; returns (server, url)."""
    p = page.payload(open_run(run), max_side=max_side)
    arrays = {k: p.array_bytes(k) for k in p.arrays}
    srv = server.make_server(page.html(p, inline=False), page.plotly_js(), arrays, port)
    server.serve_in_thread(srv)
    return srv, server.url_of(srv)


def serve(
    run: str | os.PathLike, port: int = 0, *, browser: bool = True, echo=print, max_side: int = page.MAX_SIDE
) -> None:
    """Serve the view until Ctrl-C; opens the default browser unless ``browser`` is False."""
    srv, url = start(run, port, max_side=max_side)
    try:  # from before the address is shown: a Ctrl-C as soon as it is read stops the server cleanly
        echo(f"erosim view: {url}  (127.0.0.1 only; Ctrl-C stops)")
        if browser:
            import webbrowser

            webbrowser.open(url)
        while True:
            time.sleep(3600)
    except KeyboardInterrupt:
        echo("erosim view: stopped")
    finally:
        srv.shutdown()
        srv.server_close()
