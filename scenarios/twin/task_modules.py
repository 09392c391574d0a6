"""The served controller's task T_ROB1: the modules loaded into it, each kept as a file of
the task's folder (what `rw/rapid/tasks/T_ROB1?action=loadmod` loads, and the symbols RWS
reads and writes)."""

from __future__ import annotations

import threading
from pathlib import Path

from scenarios.rapid.module import RapidModule
from scenarios.rapid.reader import read_module
from scenarios.rapid.syntax import RapidError
from scenarios.rapid.task import RapidTask, read_task
from scenarios.twin.controller_errors import ControllerError, not_allowed, not_found
from scenarios.twin.elog import EventLog
from scenarios.twin.symbols import Symbol, find, set_value


class TaskModules:
    """The modules loaded into T_ROB1, kept in `folder`; loads and unloads go to `elog`."""

    def __init__(self, folder: Path, elog: EventLog) -> None:
        self.folder = folder
        folder.mkdir(parents=True, exist_ok=True)
        self._elog = elog
        self._lock = threading.RLock()
        self._files: dict[str, Path] = {}

    def modules(self) -> list[RapidModule]:
        """The loaded modules, as read now."""
        with self._lock:
            paths = list(self._files.values())
        return [read_module(p) for p in paths]

    def names(self) -> list[str]:
        with self._lock:
            return [p.stem for p in self._files.values()]

    def load(self, data: bytes, path: str, replace: bool) -> str:
        """Load the module `data` (read from the file-service `path`); refused, with an
        event-log entry, if it does not read or is loaded already (unless `replace`)."""
        try:
            module = read_module(data.decode("utf-8", errors="strict"), path)
        except (RapidError, UnicodeDecodeError) as exc:
            self._elog.add("load_refused", f"{path}: {exc}")
            raise ControllerError(
                400, "rapid", f"{path}: the module does not load: {exc}"
            ) from None
        key = module.name.casefold()
        with self._lock:
            if key in self._files and not replace:
                raise not_allowed(
                    f"module {module.name} is loaded already (replace=true to load it again)"
                )
            target = self.folder / f"{module.name}.mod"
            target.write_bytes(data)
            self._files[key] = target
        self._elog.add("loaded", f"{module.name} from {path}")
        return module.name

    def unload(self, name: str) -> None:
        with self._lock:
            path = self._files.pop(name.casefold(), None)
            if path is None:
                loaded = ", ".join(self.names()) or "none"
                raise not_found(f"module {name!r} is not loaded (loaded: {loaded})")
            path.unlink()
        self._elog.add("unloaded", name)

    def task(self) -> RapidTask:
        """The task of the loaded modules; refused if none is loaded."""
        with self._lock:
            paths = list(self._files.values())
        if not paths:
            raise not_allowed("no module is loaded in T_ROB1")
        return read_task(paths)

    def symbol(self, path: str) -> Symbol:
        return find(self.modules(), path)

    def set_symbol(self, path: str, value: str) -> Symbol:
        """Write a RAPID datum into its module's text; the symbol as it was found."""
        with self._lock:
            symbol = self.symbol(path)
            text = set_value(symbol, value)
            self._files[symbol.module.name.casefold()].write_text(text, encoding="utf-8")
        return symbol
