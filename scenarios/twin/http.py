"""The HTTP side of the served controller, as RWS 1.0 on an IRC5 has it: HTTP/1.1 with
keep-alive, requests let through by digest authentication (scenarios.twin.digest), bodies
limited in size, and the websocket (RFC 6455) its subscriptions push events on. Resources
are routed by scenarios.twin.rws.
"""

from __future__ import annotations

import base64
import hashlib
import json
import select
import socket
import struct
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any
from urllib.parse import parse_qsl, unquote, urlsplit

from scenarios.twin.controller_errors import CODES, ControllerError
from scenarios.twin.digest import Auth

#: A body beyond this is refused (413) [bytes]; up to DRAIN it is read and dropped first, so
#: that the client reads the answer; beyond that the connection is closed.
MAX_BODY = 16 * 1024 * 1024 + 4096
DRAIN = 256 * 1024 * 1024
_WS_GUID = "258EAFA5-E914-47DA-95CA-C5AB0DC85B11"


@dataclass(frozen=True)
class Request:
    """A request as a resource sees it: method, path (decoded, no leading slash), query and
    form fields, the raw body, and the server's base URL."""

    method: str
    path: str
    query: Mapping[str, str]
    form: Mapping[str, str]
    body: bytes
    base: str


@dataclass(frozen=True)
class Response:
    """An answer: status, body and content type; `headers` added."""

    status: int
    body: bytes = b""
    content_type: str = "application/json"
    headers: tuple[tuple[str, str], ...] = ()


def state(request: Request, items: list[dict[str, Any]], status: int = 200) -> Response:
    """A JSON answer with `items` under `_embedded._state`, as RWS gives it."""
    body = {
        "_links": {"base": {"href": f"{request.base}/{request.path.rsplit('/', 1)[0]}/"}},
        "_embedded": {"_state": items},
    }
    return Response(status, json.dumps(body).encode())


def error(exc: ControllerError) -> Response:
    """An RWS error: `_embedded.status.code` and `msg`."""
    body = {
        "_links": {},
        "_embedded": {"_state": [], "status": {"code": exc.code, "msg": str(exc)}},
    }
    return Response(exc.status, json.dumps(body).encode())


NO_CONTENT = Response(204)
Route = Callable[[Request], Response]


class Server(ThreadingHTTPServer):
    """The HTTP server: `route(request)` answers requests, `upgrade(path, socket)` takes a
    websocket (both called on the request's thread)."""

    daemon_threads = True
    request_queue_size = 256
    allow_reuse_address = True

    def __init__(
        self,
        address: tuple[str, int],
        route: Route,
        upgrade: Callable[[str, socket.socket], None],
        users: dict[str, str],
    ) -> None:
        super().__init__(address, _Handler)
        self.route = route
        self.upgrade = upgrade
        self.auth = Auth(dict(users))

    @property
    def base(self) -> str:
        host, port = self.server_address[:2]
        return f"http://{host!s}:{port}"


class _Handler(BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"
    server: Server
    server_version = "twincell-rws/1.0"

    def log_message(self, format: str, *args: Any) -> None:
        return

    def do_GET(self) -> None:
        self._serve()

    def do_POST(self) -> None:
        self._serve()

    def do_PUT(self) -> None:
        self._serve()

    def do_DELETE(self) -> None:
        self._serve()

    def _serve(self) -> None:
        try:
            body = self._body()
        except ControllerError as exc:
            self._send(error(exc))
            return
        if body is None:
            return
        session = self.server.auth.check(
            self.command, self.path, self.headers.get("Authorization"), self.headers.get("Cookie")
        )
        if session is None:
            self._send(self._unauthorized())
            return
        cookie = (("Set-Cookie", f"ABBCX={session}; path=/"),)
        url = urlsplit(self.path)
        path = unquote(url.path).strip("/")
        if self.headers.get("Upgrade", "").lower() == "websocket":
            self._websocket(path)
            return
        request = Request(
            self.command,
            path,
            dict(parse_qsl(url.query, keep_blank_values=True)),
            _form(self.headers.get("Content-Type", ""), body),
            body,
            self.server.base,
        )
        try:
            response = self.server.route(request)
        except ControllerError as exc:
            response = error(exc)
        except Exception as exc:  # the server answers and serves on
            response = error(ControllerError(500, "bad_request", f"internal error: {exc!r}"))
        self._send(Response(response.status, response.body, response.content_type,
                            response.headers + cookie))  # fmt: skip

    def _body(self) -> bytes | None:
        """The request's body; None (the connection closed) for one beyond DRAIN;
        ControllerError 413 (after reading it) for one beyond MAX_BODY."""
        try:
            length = int(self.headers.get("Content-Length") or 0)
        except ValueError:
            raise ControllerError(400, "bad_request", "Content-Length is not a number") from None
        if length < 0:
            raise ControllerError(400, "bad_request", "Content-Length is negative")
        if length > DRAIN:
            self.close_connection = True
            self._send(error(_too_large(length)))
            return None
        if length > MAX_BODY:
            left = length
            while left > 0:
                chunk = self.rfile.read(min(left, 1 << 20))
                if not chunk:
                    break
                left -= len(chunk)
            raise _too_large(length)
        return self.rfile.read(length) if length else b""

    def _unauthorized(self) -> Response:
        exc = ControllerError(
            401,
            "forbidden",
            "authentication failed: a user and password of the controller are needed",
        )
        body = error(exc).body
        return Response(401, body, headers=(("WWW-Authenticate", self.server.auth.challenge()),))

    def _send(self, response: Response) -> None:
        self.send_response(response.status)
        if response.status != 204:
            self.send_header("Content-Type", response.content_type)
        self.send_header("Content-Length", str(len(response.body)))
        for key, value in response.headers:
            self.send_header(key, value)
        self.end_headers()
        if response.body and self.command != "HEAD":
            self.wfile.write(response.body)

    def _websocket(self, path: str) -> None:
        key = self.headers.get("Sec-WebSocket-Key", "")
        accept = base64.b64encode(
            hashlib.sha1((key + _WS_GUID).encode(), usedforsecurity=False).digest()
        )
        self.send_response(101)
        self.send_header("Upgrade", "websocket")
        self.send_header("Connection", "Upgrade")
        self.send_header("Sec-WebSocket-Accept", accept.decode())
        protocol = self.headers.get("Sec-WebSocket-Protocol")
        if protocol:
            self.send_header("Sec-WebSocket-Protocol", protocol.split(",")[0].strip())
        self.end_headers()
        self.wfile.flush()
        self.close_connection = True
        self.server.upgrade(path, self.connection)


def _too_large(length: int) -> ControllerError:
    return ControllerError(
        413, "too_large", f"a body of {length} bytes: at most {MAX_BODY} are taken"
    )


def _form(content_type: str, body: bytes) -> dict[str, str]:
    if not body or "json" in content_type or "octet" in content_type:
        return {}
    try:
        return dict(parse_qsl(body.decode("utf-8"), keep_blank_values=True))
    except UnicodeDecodeError:
        return {}


# -- websocket frames -------------------------------------------------------------------------
def ws_send(sock: socket.socket, text: str) -> None:
    """Send one text frame (unmasked, as a server sends)."""
    data = text.encode()
    n = len(data)
    if n < 126:
        head = struct.pack("!BB", 0x81, n)
    elif n < 1 << 16:
        head = struct.pack("!BBH", 0x81, 126, n)
    else:
        head = struct.pack("!BBQ", 0x81, 127, n)
    sock.sendall(head + data)


def ws_closed(sock: socket.socket) -> bool:
    """Whether the client closed the websocket (a close frame, or the connection gone);
    pings are answered, other frames dropped. Does not block."""
    readable, _, _ = select.select([sock], [], [], 0)
    if not readable:
        return False
    try:
        head = sock.recv(2)
        if len(head) < 2:
            return True
        opcode, n = head[0] & 0x0F, head[1] & 0x7F
        if n == 126:
            n = struct.unpack("!H", _recv(sock, 2))[0]
        elif n == 127:
            n = struct.unpack("!Q", _recv(sock, 8))[0]
        mask = _recv(sock, 4) if head[1] & 0x80 else b""
        payload = _recv(sock, n)
        if mask:
            payload = bytes(b ^ mask[i % 4] for i, b in enumerate(payload))
        if opcode == 0x9:  # ping
            sock.sendall(struct.pack("!BB", 0x8A, len(payload)) + payload)
        if opcode == 0x8:
            sock.sendall(struct.pack("!BB", 0x88, 0))
            return True
    except OSError:
        return True
    return False


def _recv(sock: socket.socket, n: int) -> bytes:
    out = b""
    while len(out) < n:
        chunk = sock.recv(n - len(out))
        if not chunk:
            raise OSError("closed")
        out += chunk
    return out


__all__ = ["CODES", "NO_CONTENT", "Request", "Response", "Server", "error", "state"]
