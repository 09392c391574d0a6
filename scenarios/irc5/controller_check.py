"""What a controller lacks for twincell's jobs (`twincell connect URL`): whether it answers and
takes the user's credentials, its RobotWare and options, the signals of the shipped EIO.cfg,
the UDP device EGM streams to (this computer, the job's --egm-port), the helper module and
its version, the motors, the operating mode, mastership, and whether a
program runs. Each finding says what the controller has and, where it falls short, what to
change. Nothing moves and nothing is written but a mastership taken and given back.
"""

from __future__ import annotations

import contextlib
import socket
from collections.abc import Callable
from dataclasses import dataclass, replace
from urllib.parse import urlparse

from scenarios.irc5.helper_module import (
    HELPER,
    HELPER_FILE,
    IO_FILE,
    OPTIONS,
    UDP_DEVICE,
    VERSION_SYMBOL,
    helper_version,
    needed_signals,
)
from scenarios.irc5.link_errors import ControllerRefusalError, LinkError
from scenarios.irc5.rws_link import RwsLink

#: The RobotWare major version whose Robot Web Services (1.0) the client speaks.
ROBOTWARE_MAJOR = 6


#: The jobs that alone need a device's signals and options (helper_module.DEVICE_SIGNALS).
DEVICE_JOBS = {
    "gripper": "jobs that grip",
    "screwer": "jobs that drive screws",
    "ir": "jobs that probe with the IR sensor",
    "point laser": "jobs with a point laser (cell.laser.kind: point)",
}


@dataclass(frozen=True)
class Finding:
    """One thing checked: what, whether it is as the jobs need it, what the controller has,
    what to change ("" if nothing), and the jobs that alone need it ("": every job)."""

    what: str
    ok: bool
    found: str
    change: str = ""
    needed_by: str = ""


@dataclass(frozen=True)
class ControllerCheck:
    """The findings on the controller at `url`, in the order checked."""

    url: str
    findings: tuple[Finding, ...]

    @property
    def ok(self) -> bool:
        """Every job's needs are met (a device's, only some jobs need, may be missing)."""
        return bool(self.findings) and not self.missing

    @property
    def missing(self) -> tuple[Finding, ...]:
        """What every job needs and the controller lacks."""
        return tuple(f for f in self.findings if not f.ok and not f.needed_by)

    @property
    def missing_for_some(self) -> tuple[Finding, ...]:
        """What only some jobs need and the controller lacks."""
        return tuple(f for f in self.findings if not f.ok and f.needed_by)


def check_controller(link: RwsLink, egm_port: int | None = None) -> ControllerCheck:
    """Check the controller `link` reaches (`egm_port`: the UDP port the job will be given,
    None: not checked); a controller that does not answer, or refuses the credentials, is
    the one finding."""
    try:
        system, options = link.call("tell its system", link.rws.system)
    except LinkError as exc:
        return ControllerCheck(link.url, (Finding("answers", False, str(exc), _REACH),))
    except ControllerRefusalError as exc:
        return ControllerCheck(link.url, (Finding("credentials", False, str(exc), _LOGIN),))
    findings = [Finding("answers", True, f"{system.get('name', '?')} at {link.url}")]
    findings.append(_robotware(system))
    findings += [_for_device(_option(o.number, o.name, o.used_for, options), o.device)
                 for o in OPTIONS]  # fmt: skip
    findings += [_for_device(_signal(link, n.name, n.type), n.device) for n in needed_signals()]
    findings.append(_udp_device(link, egm_port))
    findings.append(_helper(link))
    findings += _state(link)
    return ControllerCheck(link.url, tuple(findings))


_REACH = (
    "check the address (http://HOST:PORT of the controller's service port or its LAN port "
    "with Robot Web Services) and the network"
)
_LOGIN = "set TWINCELL_RWS_USER and TWINCELL_RWS_PASSWORD (or TWINCELL_RWS_CREDENTIALS)"


def _for_device(finding: Finding, device: str) -> Finding:
    """The finding, marked as needed by the jobs of `device` alone ("": every job)."""
    return replace(finding, needed_by=DEVICE_JOBS[device]) if device else finding


def _robotware(system: dict[str, str]) -> Finding:
    version = str(system.get("rwversionname") or system.get("rwversion") or "")
    major = version.split(".")[0]
    ok = major == str(ROBOTWARE_MAJOR)
    change = "" if ok else (
        f"twincell speaks Robot Web Services 1.0 of RobotWare {ROBOTWARE_MAJOR} (IRC5); "
        "OmniCore's RobotWare 7 serves RWS 2.0, which it does not speak yet"
    )  # fmt: skip
    return Finding("RobotWare", ok, f"RobotWare {version or 'of unknown version'}", change)


def _option(number: str, name: str, used_for: str, options: list[str]) -> Finding:
    present = [o for o in options if o.strip().startswith(number)]
    if present:
        return Finding(f"option {number}", True, present[0])
    return Finding(
        f"option {number}", False, "not installed",
        f"add {number} {name} to the RobotWare system ({used_for})",
    )  # fmt: skip


def _signal(link: RwsLink, name: str, kind: str) -> Finding:
    what = f"signal {name}"
    try:
        found = link.call(f"read {name}", lambda: link.rws.signal_type(name))
    except ControllerRefusalError:
        return Finding(what, False, "no such signal", f"add it from {IO_FILE.name} ({kind})")
    if found.upper() != kind:
        return Finding(what, False, f"a {found}", f"make it a {kind} ({IO_FILE.name})")
    return Finding(what, True, found)


def _udp_device(link: RwsLink, egm_port: int | None) -> Finding:
    """The transmission protocol the helper module streams EGM to: a UDPUC whose remote
    address is this computer's, as the controller reaches it, and whose port is the job's."""
    what, here = f"UDP device {UDP_DEVICE}", _address_towards(link.url)
    where = (
        f"Configuration > Communication > Transmission Protocol: a UDPUC named {UDP_DEVICE}, "
        f"remote address {here}"
    )
    try:
        found = link.call(
            f"read {UDP_DEVICE}", lambda: link.rws.cfg_instance("SIO", "COM_TRP", UDP_DEVICE)
        )
    except ControllerRefusalError:
        port = "" if egm_port is None else f", remote port {egm_port}"
        return Finding(what, False, "no such transmission protocol", f"add it: {where}{port}")
    kind, address = found.get("Type", "?"), found.get("RemoteAdress", "?")
    port_text = found.get("RemotePortNumber", "?")
    has = f"a {kind} to {address}:{port_text}"
    if kind != "UDPUC":
        return Finding(what, False, has, f"make it a UDPUC ({where})")
    if address != here:
        return Finding(what, False, has, f"set its remote address to {here} (this computer)")
    if egm_port is not None and port_text != str(egm_port):
        return Finding(what, False, has, f"set its remote port to {egm_port} (--egm-port)")
    return Finding(what, True, has)


def _address_towards(url: str) -> str:
    """This computer's address on the route to the controller at `url` (no packet sent)."""
    host = urlparse(url).hostname or "127.0.0.1"
    with contextlib.suppress(OSError), socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.connect((socket.gethostbyname(host), 9))
        return str(s.getsockname()[0])
    return "?"


def _helper(link: RwsLink) -> Finding:
    what, shipped = f"module {HELPER}", helper_version()
    loaded = link.call("list its modules", link.rws.module_names)
    if HELPER.casefold() not in {m.casefold() for m in loaded}:
        return Finding(
            what, False, f"not loaded in T_ROB1 (loaded: {', '.join(loaded) or 'none'})",
            f"load {HELPER_FILE} into T_ROB1",
        )  # fmt: skip
    symbol = f"{HELPER}/{VERSION_SYMBOL}"
    try:
        version = link.call(f"read {symbol}", lambda: link.rws.get_rapid_variable(symbol))
    except ControllerRefusalError:
        version = "?"
    version = version.strip('"')
    if version != shipped:
        return Finding(
            what, False, f"version {version}", f"load this twincell's {HELPER_FILE} (version "
            f"{shipped}) in its place",
        )  # fmt: skip
    return Finding(what, True, f"version {version}")


def _state(link: RwsLink) -> list[Finding]:
    """The motors, the operating mode, mastership and the program's execution."""
    rws = link.rws
    motors = link.call("tell its state", rws.get_controller_state)
    mode = link.call("tell its operation mode", rws.get_operation_mode)
    running = link.call("tell its execution state", rws.get_execution_state).ctrlexecstate
    return [
        _is("motors", motors, "motoron", "switch the motors on"),
        _is("operating mode", mode, "AUTO", "turn the key switch to automatic"),
        _mastership(link),
        _is("program", running, "stopped", "stop the program that runs (or wait for its end)"),
    ]


def _is(what: str, found: str, needed: str, change: str) -> Finding:
    return Finding(what, found == needed, found, "" if found == needed else change)


def _mastership(link: RwsLink) -> Finding:
    def take(action: str) -> Callable[[], None]:
        return lambda: link.rws.mastership(action)

    try:
        link.call("give its mastership", take("request"))
    except ControllerRefusalError as exc:
        return Finding(
            "mastership", False, str(exc),
            "release the write access held elsewhere (FlexPendant, RobotStudio)",
        )  # fmt: skip
    link.call("take its mastership back", take("release"))
    return Finding("mastership", True, "granted and released")
