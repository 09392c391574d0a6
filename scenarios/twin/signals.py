"""The controller's I/O signals (RWS `rw/iosystem/signals/Local/DRV_1/NAME`): the cell's own,
which read or drive its devices (the tool changer, the table's readout, the gripper, the
screwer, the IR sensor: scenarios.twin.cell_io), and plain user outputs and inputs a
client's program may use. Digital values are 0 or 1; analog ones in the unit their
description gives."""

from __future__ import annotations

from dataclasses import dataclass

from scenarios.twin.controller_errors import bad_request, forbidden, not_found


@dataclass(frozen=True)
class SignalSpec:
    """A signal: its name, type (DI, DO, AI, AO), what it is, and its range (analog)."""

    name: str
    type: str
    what: str
    low: float = 0.0
    high: float = 1.0

    @property
    def output(self) -> bool:
        return self.type in ("DO", "AO")

    @property
    def digital(self) -> bool:
        return self.type in ("DI", "DO")


SIGNALS: tuple[SignalSpec, ...] = (
    SignalSpec("diToolLocked", "DI", "the tool changer's lock sensor: a tool is locked"),
    SignalSpec("aiToolNumber", "AI", "the tool in hand (0 none, 1 gripper, 2 screwer, ...)", 0, 9),
    SignalSpec("aiTablePosition", "AI", "the table axis' readout [mm]", -1e4, 1e4),
    SignalSpec("diTcBeam", "DI", "the TCP check station's light barrier: its beam is broken "
               "(read while EGM streams)"),
    SignalSpec("aoGripperOpening", "AO", "each finger's opening from the centre [mm]", 0, 50),
    SignalSpec("diGripperReady", "DI", "the gripper's fingers have come to rest after its "
               "last command"),
    SignalSpec("aoSpindleSpeed", "AO", "the screwer's tightening program: the spindle's speed "
               "[rad/s]", 0, 200),
    SignalSpec("aoSpindleTime", "AO", "the screwer's tightening program: how long the spindle "
               "turns [s]", 0, 10),
    SignalSpec("doSpindleStart", "DO", "the screwer: its rising edge runs the tightening "
               "program once"),
    SignalSpec("diSpindleDone", "DI", "the screwer's program ran to its end since the start "
               "was set (0 again when it is reset)"),
    SignalSpec("aiIrRange", "AI", "the IR sensor's distance while it is in hand [mm] (0: "
               "nothing in its range)", 0, 1000),
    SignalSpec("aiLaserRange", "AI", "the point laser's distance while it is in hand [mm] (0: "
               "nothing in its range; streamed with EGM by TcHelper)", 0, 1000),
    SignalSpec("doToolLock", "DO", "the tool changer: 1 locks the tool seated against the "
               "flange, 0 releases the tool held"),
    *(SignalSpec(f"doUser{k}", "DO", "a user output") for k in range(1, 9)),
    *(SignalSpec(f"diUser{k}", "DI", "a user input (loops back doUser of its number)")
      for k in range(1, 9)),
)  # fmt: skip
BY_NAME = {s.name.casefold(): s for s in SIGNALS}


def spec(name: str) -> SignalSpec:
    """The signal `name` (any case); ControllerError 404 listing a few if unknown."""
    found = BY_NAME.get(name.casefold())
    if found is None:
        raise not_found(
            f"signal {name!r}: no such signal (e.g. {', '.join(s.name for s in SIGNALS[:5])})"
        )
    return found


def parse_value(signal: SignalSpec, text: str) -> float:
    """A value a client sets; ControllerError for an input or a value out of range."""
    if not signal.output:
        raise forbidden(f"{signal.name} is an input: it cannot be set")
    try:
        value = float(text)
    except ValueError:
        raise bad_request(f"{signal.name}: {text!r} is not a number") from None
    if signal.digital and value not in (0.0, 1.0):
        raise bad_request(f"{signal.name}: a digital signal is 0 or 1, not {text!r}")
    if not signal.low <= value <= signal.high:
        raise bad_request(f"{signal.name}: {value:g} is outside {signal.low:g}..{signal.high:g}")
    return value


def text_of(signal: SignalSpec, value: float) -> str:
    """The lvalue RWS gives: "0"/"1" for a digital signal, a number for an analog one."""
    return str(int(value)) if signal.digital else f"{value:.6g}"
