"""The controller's Robot Web Services as the client uses them (abb_robot_client's RWS, with
a timeout on every request): a module loaded and run to its end, the I/O, the event log,
the motors and the operation mode.

A request the controller refuses (an HTTP error with RWS's status) is a ControllerRefusalError
with the controller's message; a controller that does not answer within the timeout, or
whose program does not end in time, is a LinkError.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, TypeVar

import requests
from abb_robot_client.rws import RWS, ABBException, EventLogEntry

from scenarios.irc5.link_errors import ControllerRefusalError, LinkError

T = TypeVar("T")
#: Where the client's modules are written on the controller.
MODULE_FOLDER = "$TEMP"


class _TimeoutAdapter(requests.adapters.HTTPAdapter):
    """An HTTP adapter that gives every request a timeout (abb_robot_client gives none)."""

    def __init__(self, timeout_s: float) -> None:
        super().__init__()
        self.timeout_s = timeout_s

    def send(self, request: Any, **kwargs: Any) -> Any:  # type: ignore[override]
        if kwargs.get("timeout") is None:
            kwargs["timeout"] = self.timeout_s
        return super().send(request, **kwargs)


class _Rws(RWS):
    """abb_robot_client's RWS with a timeout on every request and the module load it lacks
    (POST rw/rapid/tasks/T_ROB1?action=loadmod)."""

    def __init__(self, url: str, user: str, password: str, timeout_s: float) -> None:
        super().__init__(url, user, password)
        adapter = _TimeoutAdapter(timeout_s)
        self._session.mount("http://", adapter)
        self._session.mount("https://", adapter)

    def load_module(self, path: str) -> None:
        self._do_post(
            "rw/rapid/tasks/T_ROB1?action=loadmod", {"modulepath": path, "replace": "true"}
        )

    def module_names(self) -> list[str]:
        state = self._do_get("rw/rapid/tasks/T_ROB1/modules")["_embedded"]["_state"]
        return [str(m["name"]) for m in state]

    def unload_module(self, name: str) -> None:
        self._do_post("rw/rapid/tasks/T_ROB1?action=unloadmod", {"module": name})

    def close_session(self) -> None:
        self._session.close()

    def _process_response(self, response: Any) -> Any:
        if response.status_code == 401:  # abb_robot_client raises a bare Exception for it
            raise ABBException("the user and password were refused (HTTP 401)", 401)
        return super()._process_response(response)

    def system(self) -> tuple[dict[str, str], list[str]]:
        """The RobotWare system (rw/system's sys-system-li: name, rwversion, rwversionname)
        and its options (each sys-option-li's option, e.g. "689-1 Externally Guided
        Motion")."""
        items = self._do_get("rw/system")["_embedded"]["_state"]
        system: dict[str, str] = next((i for i in items if i.get("_type") == "sys-system-li"), {})
        options = [str(i["option"]) for i in items if i.get("_type") == "sys-option-li"]
        return system, options

    def signal_type(self, name: str) -> str:
        """The type (DI, DO, AI, AO, GI, GO) of the signal `name`, where the client reads
        and writes it (abb_robot_client's Local/DRV_1)."""
        state = self._do_get(f"rw/iosystem/signals/Local/DRV_1/{name}")["_embedded"]["_state"]
        return str(state[0]["type"])

    def cfg_instance(self, domain: str, kind: str, name: str) -> dict[str, str]:
        """The attributes (title -> value) of an instance of the system configuration, e.g.
        SIO's COM_TRP `TcPC` (rw/cfg/{domain}/{kind}/instances/{name})."""
        found = self._do_get(f"rw/cfg/{domain}/{kind}/instances/{name}")["_embedded"]["_state"]
        return {str(a["_title"]): str(a.get("value", "")) for a in found[0].get("attrib", [])}

    def mastership(self, action: str) -> None:
        """Request or release the controller's mastership (write access)."""
        self._do_post(f"rw/mastership?action={action}")


class RwsLink:
    """The controller at `url` (http://HOST:PORT), as `user` with `password`; each request
    waits at most `timeout_s` [s] for its answer."""

    def __init__(self, url: str, user: str, password: str, timeout_s: float = 5.0) -> None:
        self.url = url.rstrip("/")
        self.rws = _Rws(self.url, user, password, timeout_s)
        self.timeout_s = timeout_s
        #: Requests made, and the wall time they took [s].
        self.requests = 0
        self.request_s = 0.0
        self._loaded: str | None = None

    def call(self, what: str, request: Callable[[], T]) -> T:
        """`request()` to the controller; its refusal a ControllerRefusalError, no answer a
        LinkError, each saying `what` was asked."""
        t0 = time.perf_counter()
        try:
            return request()
        except ABBException as exc:
            raise ControllerRefusalError(f"the controller refused to {what}: {exc}") from None
        except requests.RequestException as exc:
            raise LinkError(
                f"the controller at {self.url} did not answer when asked to {what} "
                f"(within {self.timeout_s:g} s): {type(exc).__name__}"
            ) from None
        finally:
            self.requests += 1
            self.request_s += time.perf_counter() - t0

    # -- state ------------------------------------------------------------------------------
    def ready(self) -> None:
        """ControllerRefusalError unless the motors are on and the controller is in automatic."""
        state = self.call("tell its state", self.rws.get_controller_state)
        mode = self.call("tell its operation mode", self.rws.get_operation_mode)
        if mode != "AUTO":
            raise ControllerRefusalError(
                f"the controller is in {mode} mode: a remote client moves the arm in AUTO only "
                "(turn the key switch to automatic)"
            )
        if state != "motoron":
            raise ControllerRefusalError(
                f"the controller's motors are off ({state}): switch them on (motoron)"
            )

    # -- programs ---------------------------------------------------------------------------
    def run_module(
        self,
        name: str,
        text: str,
        timeout_s: float,
        ended: Callable[[float], bool] | None = None,
        poll_s: float = 0.02,
    ) -> None:
        """Load the module `name` (its `text`; a module this client loaded before under
        another name is unloaded first: each has a main), run it from main, and wait for it
        to stop; LinkError if it still runs after `timeout_s` [s]. `ended(wait_s)` may tell
        the end sooner than a poll of the execution state every `poll_s` [s] would (it waits
        up to wait_s for a sign of it, e.g. the EGM stream's RAPID state)."""
        rws, path = self.rws, f"{MODULE_FOLDER}/{name}.mod"
        if self._loaded is not None and self._loaded != name:
            loaded = self._loaded
            self.call(f"unload {loaded}", lambda: rws.unload_module(loaded))
            self._loaded = None
        self.call(f"take {path}", lambda: rws.upload_file(path, text.encode("utf-8")))
        self.call(f"load {path}", lambda: rws.load_module(path))
        self._loaded = name
        self.call(f"reset the program pointer to main of {name}", rws.resetpp)
        self.call(f"start {name}", lambda: rws.start(cycle="once"))
        deadline = time.monotonic() + timeout_s
        while True:
            if ended is not None and ended(poll_s):
                return
            if ended is None:
                time.sleep(poll_s)
            state = self.call("tell its execution state", rws.get_execution_state)
            if state.ctrlexecstate != "running":
                return
            if time.monotonic() > deadline:
                self.call("stop the program", rws.stop)
                raise LinkError(f"{name} still ran after {timeout_s:g} s: stopped it")

    # -- I/O and the event log --------------------------------------------------------------
    def digital(self, signal: str) -> int:
        return self.call(f"read {signal}", lambda: self.rws.get_digital_io(signal))

    def set_digital(self, signal: str, value: int) -> None:
        self.call(f"set {signal} to {value}", lambda: self.rws.set_digital_io(signal, value))

    def analog(self, signal: str) -> float:
        return self.call(f"read {signal}", lambda: self.rws.get_analog_io(signal))

    def set_analog(self, signal: str, value: float) -> None:
        self.call(f"set {signal} to {value:g}", lambda: self.rws.set_analog_io(signal, value))

    def events(self) -> list[EventLogEntry]:
        """The event log, oldest first."""
        entries = self.call("read its event log", lambda: self.rws.read_event_log(0))
        return sorted(entries, key=lambda e: e.seqnum)

    def wait_stopped(self, timeout_s: float, poll_s: float = 0.05) -> None:
        """Wait up to `timeout_s` [s] for a program the controller runs (an earlier session's)
        to end; ControllerRefusalError if it still runs."""
        deadline = time.monotonic() + timeout_s
        while self.call("tell its execution state", self.rws.get_execution_state).ctrlexecstate == (
            "running"
        ):
            if time.monotonic() > deadline:
                raise ControllerRefusalError(
                    f"the controller still runs a program after {timeout_s:g} s: stop it (or "
                    "wait for its end) before the job takes the cell"
                )
            time.sleep(poll_s)

    def clear(self, names: tuple[str, ...]) -> list[str]:
        """Unload the modules of `names` (a client's own, left by an earlier session) that
        are loaded; the controller's other modules stay. The names unloaded."""
        loaded = self.call("list its modules", self.rws.module_names)
        gone = [n for n in loaded if n.casefold() in {m.casefold() for m in names}]
        for name in gone:
            self._unload(name)
        self._loaded = None
        return gone

    def _unload(self, name: str) -> None:
        self.call(f"unload {name}", lambda: self.rws.unload_module(name))

    def files(self, folder: str) -> list[str]:
        """The names of the files in the controller's `folder` ([] if there is none)."""
        try:
            return self.call(f"list {folder}", lambda: self.rws.list_files(folder))
        except ControllerRefusalError:
            return []

    def read_file(self, path: str) -> bytes:
        return self.call(f"read {path}", lambda: self.rws.read_file(path))

    def close(self) -> None:
        self.rws.close_session()
