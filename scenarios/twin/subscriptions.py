"""RWS subscriptions of the served controller: the resources each subscription asked for
(execution state, controller state, signals, the event log, RAPID data), the controller's
changes turned into RWS events, and each subscription's events pushed on its websocket
(`poll/N`) until the client closes it."""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import queue
import re
import threading

from aiohttp import web

from scenarios.twin.elog import ElogEntry
from scenarios.twin.signals import spec, text_of
from scenarios.twin.twin_controller import TwinController


class Subscriptions:
    """The subscriptions: their resources and the events waiting for their websocket."""

    def __init__(self, twin: TwinController) -> None:
        self._numbers = itertools.count(1)
        self._lock = threading.Lock()
        self._resources: dict[int, list[str]] = {}
        self._queues: dict[int, queue.Queue[str]] = {}
        twin.listeners.append(self._changed)
        twin.elog.listeners.append(self._logged)

    def add(self, resources: list[str]) -> int:
        number = next(self._numbers)
        with self._lock:
            self._resources[number] = resources
            self._queues[number] = queue.Queue(maxsize=1000)
        return number

    def _push(self, resource: str, event: str) -> None:
        with self._lock:
            wanted = [
                n
                for n, rs in self._resources.items()
                if any(resource.casefold() == r.casefold() for r in rs)
            ]
            for n in wanted:
                with contextlib.suppress(queue.Full):
                    self._queues[n].put_nowait(event)

    def _changed(self, resource: str, value: str) -> None:
        if resource == "execution":
            self._push(
                "/rw/rapid/execution;ctrlexecstate",
                _li(
                    "rap-ctrlexecstate-ev",
                    "/rw/rapid/execution;ctrlexecstate",
                    "ctrlexecstate",
                    value,
                ),
            )
        elif resource == "ctrlstate":
            self._push(
                "/rw/panel/ctrlstate",
                _li("pnl-ctrlstate-ev", "/rw/panel/ctrlstate", "ctrlstate", value),
            )
        elif resource.startswith("signal:"):
            name = resource[7:]
            lvalue = text_of(spec(name), float(value))
            for path in (
                f"/rw/iosystem/signals/Local/DRV_1/{name};state",
                f"/rw/iosystem/signals/{name};state",
            ):
                self._push(
                    path,
                    _li(
                        "ios-signalstate-ev",
                        f"/rw/iosystem/signals/Local/DRV_1/{name};state",
                        "lvalue",
                        lvalue,
                    ),
                )
        elif resource.startswith("rapid:"):
            url = resource[6:]
            module_less = re.sub(r"^RAPID/T_ROB1/[^/]+/", "RAPID/T_ROB1/", url)
            for path in (url, module_less):
                self._push(
                    f"/rw/rapid/symbol/data/{path};value",
                    _li("rap-data", f"/rw/rapid/symbol/data/{module_less};value", "value", value),
                )

    def _logged(self, entry: ElogEntry) -> None:
        self._push(
            "/rw/elog/0",
            _li("elog-message-ev", f"/rw/elog/0/{entry.seqnum}", "seqnum", str(entry.seqnum)),
        )

    async def serve(self, path: str, websocket: web.WebSocketResponse) -> None:
        """Push a subscription's events on its websocket, once open, until the client closes
        it (aiohttp answers its pings; what else it sends is dropped). The events are waited
        for on the loop's executor."""
        match = re.fullmatch(r"poll/(\d+)", path)
        number = int(match.group(1)) if match else -1
        with self._lock:
            events = self._queues.get(number)
        if events is None:
            await websocket.close()
            return
        loop = asyncio.get_running_loop()
        closed = asyncio.ensure_future(_until_closed(websocket))
        try:
            with contextlib.suppress(OSError):  # the client went away mid-send
                while not closed.done():
                    event = await loop.run_in_executor(None, _next, events)
                    if event is not None:
                        await websocket.send_str(_page(event))
        finally:
            closed.cancel()
            with self._lock:
                self._resources.pop(number, None)
                self._queues.pop(number, None)


async def _until_closed(websocket: web.WebSocketResponse) -> None:
    """Read the client's frames until it closes the websocket."""
    async for _ in websocket:
        continue  # a client's frames carry nothing the subscription takes


def _next(events: queue.Queue[str]) -> str | None:
    """The next event, or None if none came within 0.2 s."""
    try:
        return events.get(timeout=0.2)
    except queue.Empty:
        return None


def _li(kind: str, href: str, span: str, value: str) -> str:
    link = f'<a href="{href}" rel="self"/>'
    return f'<li class="{kind}" title="{kind}">{link}<span class="{span}">{value}</span></li>'


def _page(item: str) -> str:
    head = '<?xml version="1.0" encoding="utf-8"?><html xmlns="http://www.w3.org/1999/xhtml">'
    return f'{head}<head></head><body><div class="state"><ul>{item}</ul></div></body></html>'
