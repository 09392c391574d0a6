"""The controller's event log (RWS `rw/elog/0`): numbered entries with a type (1 information,
2 warning, 3 error), a code, a title and a description. Codes are ABB's for what a real IRC5
logs the same way (10002 program pointer reset, 10005 program stopped, 10007 program
started, 10010 motors off, 10011 motors on, 50204 motion supervision); the twin's own entries
use codes 89001 and up (EVENTS), apart from the 80001 and up that RAPID programs log with."""

from __future__ import annotations

import datetime
import threading
from collections.abc import Callable
from dataclasses import dataclass

#: What the twin logs: name -> (type, code, title).
EVENTS: dict[str, tuple[int, int, str]] = {
    "pp_reset": (1, 10002, "Program pointer has been reset"),
    "stopped": (1, 10005, "Program stopped"),
    "started": (1, 10007, "Program started"),
    "motors_off": (1, 10010, "Motors OFF state"),
    "motors_on": (1, 10011, "Motors ON state"),
    "collision": (3, 50204, "Motion supervision"),
    "loaded": (1, 89001, "Module loaded"),
    "unloaded": (1, 89002, "Module unloaded"),
    "load_refused": (3, 89003, "Module not loaded"),
    "plan_refused": (3, 89004, "Program cannot run"),
    "execution_error": (3, 89005, "Execution error"),
    "supervision": (3, 89006, "Supervision stop"),
    "lagging": (2, 89007, "Cannot keep up with the wall clock"),
    "egm": (1, 89008, "EGM"),
}
#: Entries kept (the oldest are dropped, as a controller's log wraps).
KEEP = 1000


@dataclass(frozen=True)
class ElogEntry:
    """One entry: its sequence number, type (1, 2, 3), code, title, description and wall-clock
    time stamp."""

    seqnum: int
    msgtype: int
    code: int
    title: str
    desc: str
    time: datetime.datetime


class EventLog:
    """The controller's event log; `listeners` hear each new entry (subscriptions)."""

    def __init__(self) -> None:
        self._entries: list[ElogEntry] = []
        self._lock = threading.Lock()
        self._next = 1
        self.listeners: list[Callable[[ElogEntry], None]] = []

    def add(self, event: str, desc: str) -> ElogEntry:
        """Log `event` (a key of EVENTS) with its description."""
        msgtype, code, title = EVENTS[event]
        with self._lock:
            entry = ElogEntry(self._next, msgtype, code, title, desc, datetime.datetime.now())
            self._next += 1
            self._entries.append(entry)
            del self._entries[:-KEEP]
        for listener in list(self.listeners):
            listener(entry)
        return entry

    def entries(self) -> list[ElogEntry]:
        """The entries, newest first (as RWS lists them)."""
        with self._lock:
            return self._entries[::-1]
