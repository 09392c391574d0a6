"""The HTTP side of the served controller, as RWS 1.0 on an IRC5 has it: requests and
answers as the resources (scenarios.twin.rws) see them, and the server that takes HTTP/1.1
with keep-alive, lets requests through by digest authentication (scenarios.twin.digest),
refuses bodies beyond MAX_BODY (413) and opens the websockets (RFC 6455) the subscriptions
push their events on.

The server is aiohttp's (aiohttp.web): one well-kept library that is both the HTTP/1.1
server and the websocket server, parses the requests, limits their bodies
(`client_max_size`) and runs in an asyncio event loop of our own, with no ASGI server beside
it. The loop runs in a thread of the server's own, so that the rest of the twin keeps its
threads and its blocking controller: the resources, which hand commands to the controller's
worker and wait, are answered on the loop's executor, never on the loop.
"""

from __future__ import annotations

import asyncio
import json
import logging
import threading
from collections.abc import Awaitable, Callable, Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any
from urllib.parse import unquote

from aiohttp import WSCloseCode, hdrs, web
from multidict import CIMultiDict

from scenarios.twin.controller_errors import ControllerError
from scenarios.twin.digest import SESSION, Auth

#: A body beyond this is refused (413) [bytes]; aiohttp reads and drops the rest of it (for
#: at most ten seconds) so that the client reads the answer.
MAX_BODY = 16 * 1024 * 1024 + 4096
#: The methods RWS uses; others are not implemented (501).
METHODS = frozenset({"GET", "POST", "PUT", "DELETE"})
#: Threads of the executor: the resources answered and the subscriptions waiting at once.
WORKERS = 64
#: On close, how long requests under way are given to finish [s].
SHUTDOWN_S = 2.0
SERVER = "twincell-rws/1.0"
#: What aiohttp says of requests it could not handle (one that is not HTTP is answered 400):
#: nothing, unless the application configures logging.
log = logging.getLogger(__name__)
log.addHandler(logging.NullHandler())


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
#: Serves a websocket, once open, on its path (decoded, no leading slash).
Upgrade = Callable[[str, web.WebSocketResponse], Awaitable[None]]


class Server:
    """The HTTP server on `address` (port 0: any free one), serving from a thread of its own
    until `close()`: `route(request)` answers requests (on a thread of the executor),
    `upgrade(path, websocket)` serves the websockets (on the event loop); each answer goes
    out `delay()` [s] late if given."""

    def __init__(
        self,
        address: tuple[str, int],
        route: Route,
        upgrade: Upgrade,
        users: dict[str, str],
        delay: Callable[[], float] | None = None,
    ) -> None:
        self.route = route
        #: How late each answer goes out [s] (a network's latency, injected).
        self.delay = delay
        self.upgrade = upgrade
        self.auth = Auth(dict(users))
        self.base = ""
        self._websockets: set[web.WebSocketResponse] = set()
        self._executor = ThreadPoolExecutor(WORKERS, thread_name_prefix="twin-rws")
        self._loop = asyncio.new_event_loop()
        self._loop.set_default_executor(self._executor)
        app = web.Application(client_max_size=MAX_BODY)
        app.router.add_route("*", "/{path:.*}", self._serve)
        app.on_response_prepare.append(_server_header)
        app.on_shutdown.append(self._close_websockets)
        self._runner = web.AppRunner(app, access_log=None, logger=log, shutdown_timeout=SHUTDOWN_S)
        try:
            self._loop.run_until_complete(self._start(address))
        except BaseException:
            self._loop.run_until_complete(self._runner.cleanup())
            self._loop.close()
            self._executor.shutdown(wait=False)
            raise
        self._thread = threading.Thread(target=self._loop.run_forever, name="twin-rws", daemon=True)
        self._thread.start()

    async def _start(self, address: tuple[str, int]) -> None:
        await self._runner.setup()
        site = web.TCPSite(self._runner, *address, backlog=256, reuse_address=True)
        await site.start()
        host, port = self._runner.addresses[0][:2]
        self.base = f"http://{host!s}:{port}"

    def close(self) -> None:
        """Stop serving: no new connections, the websockets closed, requests under way given
        SHUTDOWN_S to finish."""
        asyncio.run_coroutine_threadsafe(self._runner.cleanup(), self._loop).result()
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join()
        self._loop.close()
        self._executor.shutdown(wait=False)

    async def _serve(self, request: web.Request) -> web.StreamResponse:
        if request.method not in METHODS:
            raise web.HTTPNotImplemented()
        try:
            body = await request.read()
        except web.HTTPRequestEntityTooLarge:
            return _answer(error(_too_large(request.content_length)))
        session = self.auth.check(
            request.method,
            request.raw_path,
            request.headers.get(hdrs.AUTHORIZATION),
            request.cookies.get(SESSION),
        )
        if session is None:
            return _answer(self._unauthorized())
        path = unquote(request.rel_url.raw_path).strip("/")
        if request.headers.get(hdrs.UPGRADE, "").lower() == "websocket":
            return await self._websocket(request, path)
        resource_request = Request(
            request.method, path, dict(request.query), await _form(request), body, self.base
        )
        loop = asyncio.get_running_loop()
        response = await loop.run_in_executor(None, self._route, resource_request)
        if self.delay is not None and (late := self.delay()) > 0.0:
            await asyncio.sleep(late)
        return _answer(response, (hdrs.SET_COOKIE, f"{SESSION}={session}; path=/"))

    def _route(self, request: Request) -> Response:
        try:
            return self.route(request)
        except ControllerError as exc:
            return error(exc)
        except Exception as exc:  # the server answers and serves on
            return error(ControllerError(500, "bad_request", f"internal error: {exc!r}"))

    def _unauthorized(self) -> Response:
        exc = ControllerError(
            401,
            "forbidden",
            "authentication failed: a user and password of the controller are needed",
        )
        body = error(exc).body
        return Response(401, body, headers=((hdrs.WWW_AUTHENTICATE, self.auth.challenge()),))

    async def _websocket(self, request: web.Request, path: str) -> web.WebSocketResponse:
        """The websocket, opened with the first subprotocol the client offers, served by
        `upgrade` until it closes."""
        offered = request.headers.get(hdrs.SEC_WEBSOCKET_PROTOCOL)
        protocols = (offered.split(",")[0].strip(),) if offered else ()
        websocket = web.WebSocketResponse(protocols=protocols)
        await websocket.prepare(request)
        self._websockets.add(websocket)
        try:
            await self.upgrade(path, websocket)
        finally:
            self._websockets.discard(websocket)
        return websocket

    async def _close_websockets(self, app: web.Application) -> None:
        for websocket in list(self._websockets):
            await websocket.close(code=WSCloseCode.GOING_AWAY)


def _answer(response: Response, *headers: tuple[str, str]) -> web.Response:
    """aiohttp's answer for `response`, with `headers` added."""
    fields = CIMultiDict(response.headers + headers)
    if response.status != 204:
        fields[hdrs.CONTENT_TYPE] = response.content_type
    return web.Response(status=response.status, body=response.body, headers=fields)


async def _server_header(request: web.Request, response: web.StreamResponse) -> None:
    response.headers[hdrs.SERVER] = SERVER


async def _form(request: web.Request) -> dict[str, str]:
    """The form fields of a urlencoded (or multipart) body; none for other bodies, or for one
    that does not decode."""
    try:
        fields = await request.post()
    except ValueError:
        return {}
    return {key: value for key, value in fields.items() if isinstance(value, str)}


def _too_large(length: int | None) -> ControllerError:
    return ControllerError(
        413, "too_large", f"a body of {length} bytes: at most {MAX_BODY} are taken"
    )


__all__ = ["NO_CONTENT", "Request", "Response", "Server", "error", "state"]
