"""The cell's devices on the controller's I/O, as the client works them over Robot Web
Services (the signals of the shipped EIO.cfg; the twin serves them: scenarios.twin.cell_io):

- the tool changer: its lock valve `doToolLock` set and `diToolLocked` waited for, the tool
  in hand read from `aiToolNumber` (fetching and returning a tool are the controller API's
  own sequences of moves around them: scenarios.irc5.remote_controller);
- the gripper: `aoGripperOpening` [mm], then `diGripperReady` waited for (the fingers at
  rest, on the part or at the opening);
- the screwer: its tightening program's `aoSpindleSpeed` [rad/s] and `aoSpindleTime` [s],
  `doSpindleStart` set, `diSpindleDone` waited for, the start reset (a handshake, as with
  a screwdriver's own controller);
- the IR sensor: `aiIrRange` [mm], 0 where nothing is in its range;
- the motion supervision: switched off for the moves run meanwhile, by `MotionSup \\Off` in
  each move's module (RobotWare's 613-1 Collision Detection), as a program switches it
  off around a grip.

A device that does not answer within its time is asked about in the event log (`why`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import NoReturn

from scenarios.irc5.link_errors import ControllerRefusalError
from scenarios.irc5.rws_link import RwsLink

#: How long a device may take beyond its own time before the client asks why [s] (wall
#: clock: a controller's time runs at most as fast as the wall's).
MARGIN_S = 5.0
#: How often an input is polled while waited for [s].
POLL_S = 0.005


class Devices:
    """The devices behind the controller at `link`; `why(what)` raises what the event log
    says of a device that did not answer (scenarios.irc5.remote_controller)."""

    def __init__(self, link: RwsLink, why: Callable[[str], NoReturn]) -> None:
        self.link = link
        self._why = why
        #: The motion supervision watches the moves (False inside `supervision_off`).
        self.supervised = True

    def wait_input(self, signal: str, value: int, timeout_s: float, what: str) -> None:
        """Wait for the digital input `signal` to read `value` (a RAPID WaitDI \\MaxTime)."""
        deadline = time.monotonic() + timeout_s
        while self.link.digital(signal) != value:
            if time.monotonic() > deadline:
                self._why(what)
            time.sleep(POLL_S)

    def tool_in_hand(self, tools: tuple[str, ...]) -> str | None:
        """The tool `aiToolNumber` names, of the cell's `tools` (its place in the rack, from
        1; 0: none)."""
        number = round(self.link.analog("aiToolNumber"))
        if number == 0:
            return None
        if not 1 <= number <= len(tools):
            raise ControllerRefusalError(
                f"aiToolNumber says tool {number}; the cell's tools are 1..{len(tools)}: "
                f"{', '.join(tools)}"
            )
        return tools[number - 1]

    def set_lock(self, value: int) -> None:
        """The tool changer's lock valve `doToolLock` set, `diToolLocked` waited for."""
        self.link.set_digital("doToolLock", value)
        self.wait_input("diToolLocked", value, MARGIN_S, "the tool changer")

    def set_gripper(self, opening_m: float) -> None:
        """Each finger to `opening_m` [m] from the centre, or onto the part between them."""
        self.link.set_analog("aoGripperOpening", opening_m * 1e3)
        self.wait_input("diGripperReady", 1, MARGIN_S, "the gripper")

    def spin_screwer(self, rad_s: float, seconds: float) -> None:
        """The screwer's tightening program: the spindle at `rad_s` [rad/s] for `seconds`."""
        self.link.set_analog("aoSpindleSpeed", rad_s)
        self.link.set_analog("aoSpindleTime", seconds)
        self.link.set_digital("doSpindleStart", 1)
        try:
            self.wait_input("diSpindleDone", 1, seconds + MARGIN_S, "the screwer")
        finally:
            self.link.set_digital("doSpindleStart", 0)

    def read_ir(self) -> float | None:
        """The IR sensor's distance [m]; None where nothing is in its range."""
        range_mm = self.link.analog("aiIrRange")
        return None if range_mm <= 0.0 else range_mm * 1e-3

    @contextmanager
    def supervision_off(self) -> Iterator[None]:
        self.supervised = False
        try:
            yield
        finally:
            self.supervised = True
