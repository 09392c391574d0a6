"""The served controller's I/O over the cell's devices: what each signal reads from the
cell, and what writing an output makes the cell do.

Inputs are read from the newest snapshot (scenarios.twin.snapshot), which the worker
publishes; outputs that drive a device hand the device's command to the worker (the one
thread that moves the cell), with the handshake a cell's PLC or the device's own controller
gives:

- `doToolLock`: the tool changer locks the tool seated against the flange, or releases it;
  `diToolLocked` and `aiToolNumber` follow.
- `aoGripperOpening` [mm]: the fingers move to that opening (force-limited, they stop on
  a part); `diGripperReady` is 0 from the command until they have come to rest.
- `doSpindleStart`: on its rising edge the screwer runs its tightening program once, the
  spindle at `aoSpindleSpeed` [rad/s] for `aoSpindleTime` [s] of the controller's time;
  `diSpindleDone` is 1 once it has, and 0 again when the start is reset.
- `aiIrRange` [mm]: the IR sensor's distance while it is in hand; 0 where nothing is in its
  range.
- `aiLaserRange` [mm]: the point laser's distance while it is in hand, as the streams last
  set it (scenarios.twin.sensor_streams); 0 where nothing is in its range.
"""

from __future__ import annotations

from collections.abc import Callable

from cell import CellError, Controller, SupervisionError
from scenarios.twin.controller_errors import not_allowed
from scenarios.twin.elog import EventLog
from scenarios.twin.signals import SIGNALS, SignalSpec
from scenarios.twin.snapshot import Snapshot

#: The outputs whose writing moves a device of the cell, and the tool it needs in hand
#: (None: any, or none).
DEVICE_OUTPUTS: dict[str, str | None] = {
    "doToolLock": None,
    "aoGripperOpening": "gripper",
    "doSpindleStart": "screwer",
}


class CellIo:
    """The signals' values and the devices behind them, over the cell `cell`: `submit`
    runs a command on the worker, `relock` locks the worker's pace to the cell's time before
    a device moves, `refresh` publishes a snapshot after it, `changed(resource, value)`
    tells the subscribers."""

    def __init__(
        self,
        cell: Controller,
        elog: EventLog,
        submit: Callable[[Callable[[], None]], None],
        relock: Callable[[float], None],
        refresh: Callable[[], None],
        changed: Callable[[str, str], None],
    ) -> None:
        self.cell = cell
        self.values: dict[str, float] = {s.name: 0.0 for s in SIGNALS}
        self.values["diGripperReady"] = 1.0
        self._elog = elog
        self._submit = submit
        self._relock = relock
        self._refresh = refresh
        self._changed = changed
        self._tools = cell.tools

    def read(self, spec: SignalSpec, snap: Snapshot) -> float:
        """A signal's value now: the cell's inputs as the snapshot `snap` has them (live
        while a program runs, as a controller's inputs are), the outputs as set."""
        name = spec.name
        if name.startswith("diUser"):
            return self.values["doUser" + name[6:]]
        if name == "diTcBeam":
            return float(snap.beam)
        if name == "diToolLocked":
            return float(snap.tool is not None)
        if name == "aiToolNumber":
            tools = self._tools
            return float(tools.index(snap.tool) + 1) if snap.tool in tools else 0.0
        if name == "aiTablePosition":
            return snap.table_m * 1e3
        if name == "aiIrRange":
            return 0.0 if snap.ir_m is None else snap.ir_m * 1e3
        return self.values[name]

    def write(self, spec: SignalSpec, value: float) -> None:
        """Set an output (its value checked by the caller): a device's output hands its
        command to the worker; ControllerError 405 if the device's tool is not in hand."""
        name = spec.name
        needs = DEVICE_OUTPUTS.get(name)
        if needs is not None and self.cell.tool_in_hand != needs:
            raise not_allowed(f"{name}: the {needs} is not in hand")
        rising = value == 1.0 and self.values[name] == 0.0
        self._set(name, value)
        if name == "doToolLock":
            self._submit(lambda: self._tool_lock(value == 1.0))
        elif name == "aoGripperOpening":
            self._set("diGripperReady", 0.0)
            self._submit(lambda: self._gripper(value))
        elif name == "doSpindleStart":
            self._set("diSpindleDone", 0.0)
            if rising:
                speed, seconds = self.values["aoSpindleSpeed"], self.values["aoSpindleTime"]
                self._submit(lambda: self._spindle(speed, seconds))

    def _set(self, name: str, value: float) -> None:
        self.values[name] = value
        self._changed(f"signal:{name}", str(value))

    def _tool_lock(self, lock: bool) -> None:
        """Lock the tool seated against the flange, or release the one held (on the worker);
        a lock the supervision refuses is in the event log, and no tool is held."""
        self._relock(self.cell.time_s)
        try:
            if lock:
                self.cell.lock()
            else:
                self.cell.unlock()
        except SupervisionError as exc:
            self._elog.add("supervision", str(exc))
        except CellError as exc:
            self._elog.add("execution_error", f"the tool changer: {exc}")
        finally:
            self._refresh()

    def _gripper(self, opening_mm: float) -> None:
        self._relock(self.cell.time_s)
        try:
            self.cell.set_gripper(opening_mm * 1e-3)
        except CellError as exc:
            self._elog.add("execution_error", f"the gripper: {exc}")
        finally:
            self._refresh()
            self._set("diGripperReady", 1.0)

    def _spindle(self, speed_rad_s: float, seconds: float) -> None:
        self._relock(self.cell.time_s)
        try:
            self.cell.spin_screwer(speed_rad_s, seconds)
        except CellError as exc:
            self._elog.add("execution_error", f"the screwer: {exc}")
            return
        finally:
            self._refresh()
        if self.values["doSpindleStart"] == 1.0:  # a start reset meanwhile asks no answer
            self._set("diSpindleDone", 1.0)
