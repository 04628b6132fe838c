"""The local server of ``erosim view``: the page, plotly.js and the run's arrays, on 127.0.0.1 only.

Why a server at all: a 1024² run's arrays are tens of megabytes; served as raw bytes (``data/NAME``)
the browser fetches only what it draws (the height first, a layer when it is switched on, a frame
when the slider reaches it), so the first picture comes fast. Why safe: it binds to the loopback
address only, and it serves a fixed set of names held in memory — the page, ``plotly.min.js`` and
the arrays :func:`erosim.view.page.payload` made — never a path of the file system; a request whose
path holds ``..`` (also percent-encoded) is refused with 403, any other unknown name with 404.
"""

from __future__ import annotations

import threading
import urllib.parse
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

from erosim.core.errors import InputError

HOST = "127.0.0.1"


def _handler(routes: dict[str, tuple[str, bytes]]):
    class Handler(BaseHTTPRequestHandler):
        server_version = "erosim-view"

        def log_message(self, format, *args):  # noqa: A002 - quiet: the terminal shows the URL only
            pass

        def _send(self, code: int, ctype: str, body: bytes) -> None:
            self.send_response(code)
            self.send_header("Content-Type", ctype)
            self.send_header("Content-Length", str(len(body)))
            # plotly.js is the same for every run: the browser may keep it (and its compiled code)
            self.send_header("Cache-Control", "max-age=86400" if self.path == "/plotly.min.js" else "no-store")
            self.end_headers()
            if self.command != "HEAD":
                self.wfile.write(body)

        def do_GET(self):  # noqa: N802 - the http.server interface
            raw = self.path.split("?", 1)[0].split("#", 1)[0]
            path = raw
            for _ in range(3):  # decode %2e%2e and %252e… alike before looking for ..
                path = urllib.parse.unquote(path)
            if ".." in path or "\\" in path:
                self._send(403, "text/plain; charset=utf-8", b"Refused: the path leaves the view's files.\n")
                return
            name = "/" if path in ("", "/", "/index.html") else path
            if name not in routes:
                self._send(404, "text/plain; charset=utf-8", b"Not found: the view serves its page and data only.\n")
                return
            ctype, body = routes[name]
            self._send(200, ctype, body)

        do_HEAD = do_GET

    return Handler


def make_server(page: str, plotly_js: bytes, arrays: dict[str, bytes], port: int = 0) -> ThreadingHTTPServer:
    """A server on 127.0.0.1:``port`` (0: any free port) holding the page, plotly.js and ``arrays``."""
    if not 0 <= port <= 65535:
        raise InputError(f"--port {port} is not a port; give a number from 1024 to 65535, or 0 for any free one.")
    routes = {"/": ("text/html; charset=utf-8", page.encode("utf-8")), "/plotly.min.js": ("text/javascript", plotly_js)}
    for name, data in arrays.items():
        routes["/data/" + name] = ("application/octet-stream", data)
    try:
        return ThreadingHTTPServer((HOST, port), _handler(routes))
    except OSError as exc:
        raise InputError(f"Cannot listen on {HOST}:{port} ({exc.strerror}); choose another --port.") from None


def serve_in_thread(server: ThreadingHTTPServer) -> threading.Thread:
    t = threading.Thread(target=server.serve_forever, daemon=True)
    t.start()
    return t


def url_of(server: ThreadingHTTPServer) -> str:
    host, port = server.server_address[:2]
    return f"http://{host}:{port}/"
