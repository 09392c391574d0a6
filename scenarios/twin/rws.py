"""Robot Web Services 1.0 resources of the served controller, as an IRC5 with RobotWare 6
answers them (JSON with `json=1`: the state under `_embedded._state`, each item with its
`_type`; errors under `_embedded.status`), routed over scenarios.twin.twin_controller:

- `rw/panel/ctrlstate`, `opmode`, `speedratio` (and their set actions);
- `rw/rapid/execution` (start, stop, resetpp), `rw/rapid/tasks[/T_ROB1]` (activate,
  deactivate, loadmod, unloadmod; `/modules`), `rw/rapid/symbol/data/RAPID/T_ROB1/...` (get,
  set), `rw/rapid/symbols?action=search-symbols`;
- `rw/iosystem/signals[/Local/DRV_1/NAME]` (get, set);
- `rw/motionsystem/mechunits/ROB_1/jointtarget`, `/robtarget?tool=&wobj=&coordinate=`;
- `rw/cfg/SIO/COM_TRP/instances/NAME` (the UDP device EGM streams to, when it does);
- `rw/system` (the RobotWare version and options); `rw/elog/0`; `rw/mastership` (request,
  release: in automatic mode only); `ctrl/$RAMDISK`, `ctrl/$HOME`;
- `fileservice/$HOME/...`, `fileservice/$RAMDISK/...` (PUT, GET, DELETE, folder listings);
- `subscription` (execution state, controller state, operation mode, signals, event log,
  RAPID data) with its events on a websocket (`poll/N`); `logout`.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from scenarios.rapid.planner import cell_tools
from scenarios.twin.controller_errors import bad_request, not_found
from scenarios.twin.elog import ElogEntry
from scenarios.twin.http import NO_CONTENT, Request, Response, state
from scenarios.twin.signals import SIGNALS, spec, text_of
from scenarios.twin.subscriptions import Subscriptions
from scenarios.twin.twin_controller import TwinController

Handler = Callable[[Request, str], Response]
#: The RobotWare the twin answers as: an IRC5's RobotWare 6, with the options the jobs use.
ROBOTWARE = "6.15.03.00"
OPTIONS = (
    "RobotWare Base",
    "616-1 PC Interface",
    "613-1 Collision Detection",
    "689-1 Externally Guided Motion",
)


class Rws:
    """The resources of the served controller `twin`."""

    def __init__(self, twin: TwinController) -> None:
        self.twin = twin
        self.subscriptions = Subscriptions(twin)
        #: The system configuration's UDP devices: name -> (remote address, port).
        self.udp_devices: dict[str, tuple[str, int]] = {}
        p = self
        self.routes: list[tuple[str, re.Pattern[str], Handler]] = [
            (m, re.compile(rx + "$"), h)
            for m, rx, h in (
                ("GET", r"rw/panel/ctrlstate", p.ctrlstate),
                ("POST", r"rw/panel/ctrlstate", p.set_ctrlstate),
                ("GET", r"rw/panel/opmode", p.opmode),
                ("GET", r"rw/panel/speedratio", p.speedratio),
                ("POST", r"rw/panel/speedratio", p.set_speedratio),
                ("GET", r"rw/rapid/execution", p.execution),
                ("POST", r"rw/rapid/execution", p.execute),
                ("GET", r"rw/rapid/tasks", p.tasks),
                ("GET", r"rw/rapid/tasks/T_ROB1", p.tasks),
                ("POST", r"rw/rapid/tasks/T_ROB1", p.task_action),
                ("GET", r"rw/rapid/tasks/T_ROB1/modules", p.modules),
                ("GET", r"rw/rapid/symbol/data/RAPID/(.+)", p.symbol),
                ("POST", r"rw/rapid/symbol/data/RAPID/(.+)", p.set_symbol),
                ("POST", r"rw/rapid/symbols", p.search),
                ("GET", r"rw/iosystem/signals", p.signals),
                ("GET", r"rw/iosystem/signals/(?:Local/DRV_1/)?([^/]+)", p.signal),
                ("POST", r"rw/iosystem/signals/(?:Local/DRV_1/)?([^/]+)", p.set_signal),
                ("GET", r"rw/motionsystem/mechunits/ROB_1/jointtarget", p.jointtarget),
                ("GET", r"rw/motionsystem/mechunits/ROB_1/robtarget", p.robtarget),
                ("GET", r"rw/elog/0", p.elog),
                ("GET", r"rw/system", p.system),
                ("GET", r"rw/cfg/SIO/COM_TRP/instances/([^/]+)", p.udp_device),
                ("POST", r"rw/mastership(?:/.*)?", p.mastership),
                ("GET", r"ctrl/\$(RAMDISK|HOME|TEMP)", p.ctrl_path),
                ("GET", r"fileservice/(.+)", p.read_file),
                ("PUT", r"fileservice/(.+)", p.write_file),
                ("DELETE", r"fileservice/(.+)", p.delete_file),
                ("POST", r"subscription", p.subscribe),
                ("GET", r"logout", lambda _r, _a: NO_CONTENT),
            )
        ]

    def route(self, request: Request) -> Response:
        """The answer to `request` (ControllerError for what is refused)."""
        known = False
        for method, pattern, handler in self.routes:
            match = pattern.match(request.path)
            if match is None:
                continue
            known = True
            if method == request.method:
                return handler(request, match.group(1) if match.groups() else "")
        if known:
            raise bad_request(f"{request.method} {request.path}: method not allowed here")
        raise not_found(f"{request.path}: no such resource")

    # -- panel ------------------------------------------------------------------------------
    def ctrlstate(self, r: Request, arg: str = "") -> Response:
        return state(
            r, [{"_type": "pnl-ctrlstate", "_title": "ctrlstate", "ctrlstate": self.twin.ctrlstate}]
        )

    def set_ctrlstate(self, r: Request, arg: str = "") -> Response:
        _action(r, "setctrlstate")
        self.twin.set_ctrlstate(_field(r, "ctrl-state"))
        return NO_CONTENT

    def opmode(self, r: Request, arg: str = "") -> Response:
        return state(r, [{"_type": "pnl-opmode", "_title": "opmode", "opmode": self.twin.opmode}])

    def speedratio(self, r: Request, arg: str = "") -> Response:
        ratio = str(self.twin.speedratio)
        return state(r, [{"_type": "pnl-speedratio", "_title": "speedratio", "speedratio": ratio}])

    def set_speedratio(self, r: Request, arg: str = "") -> Response:
        _action(r, "setspeedratio")
        self.twin.set_speedratio(_number(_field(r, "speed-ratio"), "speed-ratio"))
        return NO_CONTENT

    # -- execution and the task -------------------------------------------------------------
    def execution(self, r: Request, arg: str = "") -> Response:
        item = {"_type": "rap-execution", "_title": "execution",
                "ctrlexecstate": self.twin.execstate, "cycle": self.twin.cycle}  # fmt: skip
        return state(r, [item])

    def execute(self, r: Request, arg: str = "") -> Response:
        action = r.query.get("action")
        if action == "start":
            cycle = r.form.get("cycle", "asis")
            if cycle not in ("asis", "once", "forever", "oncedone"):
                raise bad_request(f"cycle {cycle!r}: give asis, once or forever")
            if cycle == "forever":
                raise bad_request("cycle forever: the twin runs a program once per start")
            self.twin.start()
        elif action == "stop":
            self.twin.stop()
        elif action == "resetpp":
            self.twin.resetpp()
        else:
            raise bad_request(f"action {action!r}: give start, stop or resetpp")
        return NO_CONTENT

    def tasks(self, r: Request, arg: str = "") -> Response:
        running = self.twin.execstate == "running"
        item = {"_type": "rap-task-li", "_title": "T_ROB1", "name": "T_ROB1", "type": "norm",
                "taskstate": "started" if running else "linked",
                "excstate": "started" if running else "ready",
                "active": "On", "motiontask": "TRUE"}  # fmt: skip
        return state(r, [item])

    def task_action(self, r: Request, arg: str = "") -> Response:
        action = r.query.get("action")
        if action in ("activate", "deactivate"):
            if action == "deactivate":
                raise bad_request("T_ROB1 is the twin's only motion task: it stays active")
        elif action == "loadmod":
            replace = r.form.get("replace", "false").lower() == "true"
            self.twin.load_module(_field(r, "modulepath"), replace)
        elif action == "unloadmod":
            self.twin.unload_module(_field(r, "module"))
        else:
            raise bad_request(f"action {action!r}: give activate, deactivate, loadmod or unloadmod")
        return NO_CONTENT

    def modules(self, r: Request, arg: str = "") -> Response:
        items = [{"_type": "rap-module-info-li", "_title": n, "name": n, "type": "ProgMod"}
                 for n in self.twin.module_names()]  # fmt: skip
        return state(r, items)

    def symbol(self, r: Request, arg: str = "") -> Response:
        path = _name(r, arg)
        if path.endswith(";value"):
            path = path[: -len(";value")]
        symbol = self.twin.symbol(path)
        return state(r, [{"_type": "rap-data", "_title": symbol.url, "value": symbol.value}])

    def set_symbol(self, r: Request, arg: str = "") -> Response:
        _action(r, "set")
        self.twin.set_symbol(_name(r, arg), _field(r, "value"))
        return NO_CONTENT

    def search(self, r: Request, arg: str = "") -> Response:
        _action(r, "search-symbols")
        block = r.form.get("blockurl", "RAPID/T_ROB1")
        if block.rstrip("/") not in ("RAPID", "RAPID/T_ROB1") and not block.upper().startswith(
            "RAPID/T_ROB1/"
        ):
            return state(r, [])
        from scenarios.twin.symbols import SYMTYP, search

        symtyp = {"per": "per", "var": "var", "con": "con"}.get(r.form.get("symtyp", "any"), "any")
        found = search(self.twin.modules(), symtyp, r.form.get("regexp", ""))
        items = []
        for s in found:
            d, symtyp = s.declaration, SYMTYP.get(s.declaration.storage, "var")
            local = str(d.scope == "LOCAL").upper()
            items.append({"_type": f"rap-sym{symtyp}-li", "_title": s.url, "name": d.name,
                          "symburl": s.url, "dattyp": d.datatype, "symtyp": symtyp,
                          "local": local})  # fmt: skip
        return state(r, items)

    # -- I/O ---------------------------------------------------------------------------------
    def _signal_item(self, name: str) -> dict[str, str]:
        s = spec(name)
        value = text_of(s, self.twin.signal(s))
        return {"_type": "ios-signal-li", "_title": f"Local/DRV_1/{s.name}", "name": s.name,
                "type": s.type, "category": "", "lvalue": value,
                "lstate": "not simulated"}  # fmt: skip

    def signals(self, r: Request, arg: str = "") -> Response:
        return state(r, [self._signal_item(s.name) for s in SIGNALS])

    def signal(self, r: Request, arg: str = "") -> Response:
        name = _name(r, arg).removesuffix(";state")
        return state(r, [self._signal_item(name)])

    def set_signal(self, r: Request, arg: str = "") -> Response:
        _action(r, "set")
        self.twin.set_signal(spec(_name(r, arg)), _field(r, "lvalue"))
        return NO_CONTENT

    # -- motion ------------------------------------------------------------------------------
    def jointtarget(self, r: Request, arg: str = "") -> Response:
        snap = self.twin.snapshot
        item: dict[str, Any] = {"_type": "ms-jointtarget", "_title": "ROB_1"}
        for k, angle in enumerate(np.rad2deg(snap.q), start=1):
            item[f"rax_{k}"] = f"{angle:.6f}"
        for axis in "abcdef":
            item[f"eax_{axis}"] = f"{snap.table_m * 1e3:.6f}" if axis == "a" else "9E+09"
        return state(r, [item])

    def robtarget(self, r: Request, arg: str = "") -> Response:
        coordinate = r.query.get("coordinate", "Base")
        if coordinate not in ("Base", "World", "Wobj"):
            raise bad_request(f"coordinate {coordinate!r}: give Base, World or Wobj")
        snap = self.twin.snapshot
        T_flange_tcp = self._tool(r.query.get("tool", "tool0"))
        T_base_oframe = (
            self._wobj(r.query.get("wobj", "wobj0")) if coordinate == "Wobj" else np.eye(4)
        )
        T = np.linalg.inv(T_base_oframe) @ snap.T_base_flange @ T_flange_tcp
        x, y, z, w = Rotation.from_matrix(T[:3, :3]).as_quat()
        item: dict[str, Any] = {"_type": "ms-robtargets", "_title": "ROB_1"}
        item |= dict(zip("xyz", (f"{v:.4f}" for v in T[:3, 3] * 1e3), strict=True))
        item |= dict(zip(("q1", "q2", "q3", "q4"), (f"{v:.7f}" for v in (w, x, y, z)), strict=True))
        item |= {"cf1": "0", "cf4": "0", "cf6": "0", "cfx": "0"}
        item |= {
            f"eax{a}": (f"{snap.table_m * 1e3:.4f}" if a == "a" else "9E+09") for a in "abcdef"
        }
        return state(r, [item])

    def _tool(self, name: str) -> np.ndarray:
        """A tooldata's TCP T_flange_tcp (4, 4) [m]: tool0, one declared in the loaded task,
        or a cell tool by name."""
        if name.casefold() == "tool0":
            return np.eye(4)
        for module in self.twin.modules():
            for declared, tool in module.tools.items():
                if declared.casefold() == name.casefold():
                    return np.asarray(tool.T_flange_tcp, dtype=float)
        tools = cell_tools(self.twin.cell)
        if name in tools:
            return tools[name]
        raise not_found(
            f"tool {name!r}: not tool0, not declared in the loaded modules, not a cell tool"
        )

    def _wobj(self, name: str) -> np.ndarray:
        if name.casefold() == "wobj0":
            return np.eye(4)
        for module in self.twin.modules():
            for declared, wobj in module.wobjs.items():
                if declared.casefold() == name.casefold():
                    return np.asarray(wobj.T_base_uframe @ wobj.T_uframe_oframe, dtype=float)
        raise not_found(f"wobj {name!r}: not wobj0 and not declared in the loaded modules")

    # -- the system, mastership, the event log, files ----------------------------------------
    def system(self, r: Request, arg: str = "") -> Response:
        items = [{"_type": "sys-system-li", "_title": "system", "name": "twincell twin",
                  "rwversion": ROBOTWARE, "rwversionname": ROBOTWARE}]  # fmt: skip
        items += [{"_type": "sys-option-li", "_title": o, "option": o} for o in OPTIONS]
        return state(r, items)

    def udp_device(self, r: Request, arg: str = "") -> Response:
        """A transmission protocol of the system configuration (RWS's cfg instance: each
        attribute's `_title` and `value`; ABB spells RemoteAdress so)."""
        name = _name(r, arg)
        found = {n.casefold(): (n, d) for n, d in self.udp_devices.items()}.get(name.casefold())
        if found is None:
            raise not_found(f"COM_TRP instance {name!r}: no such transmission protocol")
        (title, (host, port)) = found
        values = {"Name": title, "Type": "UDPUC", "RemoteAdress": host, "RemotePortNumber": port}
        attrib = [{"_type": "cfg-ia-t-li", "_title": k, "value": str(v)} for k, v in values.items()]
        return state(r, [{"_type": "cfg-dt-instance-li", "_title": title, "attrib": attrib}])

    def mastership(self, r: Request, arg: str = "") -> Response:
        action = r.query.get("action")
        if action not in ("request", "release"):
            raise bad_request(f"{r.path}: action {action!r}: give request or release")
        if action == "request":
            self.twin.require_auto("take mastership")
        return NO_CONTENT

    def elog(self, r: Request, arg: str = "") -> Response:
        items = [_elog_item(e) for e in self.twin.elog.entries()]
        return state(r, items)

    def ctrl_path(self, r: Request, arg: str = "") -> Response:
        return state(
            r, [{"_type": "ctrl-var", "_title": f"${_name(r, arg)}", "_value": f"${_name(r, arg)}"}]
        )

    def read_file(self, r: Request, arg: str = "") -> Response:
        path = _name(r, arg)
        target = self.twin.files.resolve(path)
        if target.is_dir():
            listing = self.twin.files.listing(path)
            items = [{"_type": "fs-dir" if is_dir else "fs-file", "_title": name,
                      "fs-size": str(size)} for name, is_dir, size in listing]  # fmt: skip
            return state(r, items)
        return Response(200, self.twin.files.read(path), "application/octet-stream")

    def write_file(self, r: Request, arg: str = "") -> Response:
        self.twin.files.write(_name(r, arg), r.body)
        return Response(201)

    def delete_file(self, r: Request, arg: str = "") -> Response:
        self.twin.files.delete(_name(r, arg))
        return NO_CONTENT

    def subscribe(self, r: Request, arg: str = "") -> Response:
        resources = [r.form[k] for k in r.form if k.isdigit()]
        if not resources:
            raise bad_request("a subscription names its resources (1=/rw/..., 1-p=1, ...)")
        number = self.subscriptions.add(resources)
        host = r.base.removeprefix("http://")
        body = (
            '<?xml version="1.0" encoding="utf-8"?><html xmlns="http://www.w3.org/1999/xhtml">'
            f'<head><base href="{r.base}/"/></head><body>'
            f'<a href="ws://{host}/poll/{number}" rel="self">{number}</a></body></html>'
        )
        return Response(201, body.encode(), "application/xhtml+xml;v=2.0",
                        (("Location", f"ws://{host}/poll/{number}"),))  # fmt: skip


def _name(r: Request, arg: str) -> str:
    if not arg:
        raise bad_request(f"{r.path}: the resource needs a name")
    return arg


def _action(r: Request, action: str) -> None:
    if r.query.get("action") != action:
        raise bad_request(f"{r.path}: action {r.query.get('action')!r}: give action={action}")


def _field(r: Request, name: str) -> str:
    value = r.form.get(name)
    if value is None:
        raise bad_request(f"{r.path}: the form field {name!r} is missing")
    return value


def _number(text: str, what: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise bad_request(f"{what} {text!r} is not a number") from None


def _elog_item(e: ElogEntry) -> dict[str, str]:
    return {"_type": "elog-message-li", "_title": f"/rw/elog/0/{e.seqnum}",
            "msgtype": str(e.msgtype), "code": str(e.code),
            "tstamp": e.time.strftime("%Y-%m-%d T  %H:%M:%S"), "title": e.title, "desc": e.desc,
            "conseqs": "", "causes": "", "actions": "", "argc": "0"}  # fmt: skip
