"""What a controller needs for twincell's jobs, as shipped in `controller_files/`: the helper
module TcHelper.sys (loaded into T_ROB1 once), the signals of EIO.cfg, and the RobotWare
options they need. `twincell connect` checks a controller against them, and `twincell serve`
loads the same helper module into the twin.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from scenarios.rapid.reader import read_module

#: The shipped files a user loads on the controller.
FOLDER = Path(__file__).parent / "controller_files"
HELPER_FILE = FOLDER / "TcHelper.sys"
IO_FILE = FOLDER / "EIO.cfg"
#: The helper module's name, and the PROC each module the client runs calls first.
HELPER = "TcHelper"
STREAM_PROC = "TcStream"
#: The helper's CONST that says which version of it is loaded.
VERSION_SYMBOL = "tcHelperVersion"
#: The transmission protocol (a UDPUC) TcStream sets EGM up for: its remote address and port
#: are the job's computer's and its --egm-port.
UDP_DEVICE = "TcPC"


#: The signals and options a device needs, by the tool that carries it: only jobs that use
#: the tool need them (the others run on a controller without them).
DEVICE_SIGNALS: dict[str, str] = {
    "aoGripperOpening": "gripper",
    "diGripperReady": "gripper",
    "aoSpindleSpeed": "screwer",
    "aoSpindleTime": "screwer",
    "doSpindleStart": "screwer",
    "diSpindleDone": "screwer",
    "aiIrRange": "ir",
    "aiLaserRange": "point laser",
}


@dataclass(frozen=True)
class RobotWareOption:
    """A RobotWare option: its number (as the controller's option list begins) and name,
    what the jobs use it for, and the tool whose jobs alone need it ("": every job)."""

    number: str
    name: str
    used_for: str
    device: str = ""


OPTIONS: tuple[RobotWareOption, ...] = (
    RobotWareOption(
        "616-1", "PC Interface", "Robot Web Services: modules, program start, I/O, files"
    ),
    RobotWareOption(
        "689-1", "Externally Guided Motion", "the joints and the beam streamed every 4 ms"
    ),
    RobotWareOption(
        "613-1", "Collision Detection", "MotionSup \\Off around a grip", device="gripper"
    ),
)


@dataclass(frozen=True)
class SignalNeed:
    """A signal the jobs use: its name and type (DI, DO, AI, AO), and the tool whose jobs
    alone need it ("": every job)."""

    name: str
    type: str
    device: str = ""


def helper_text() -> str:
    """TcHelper.sys as shipped."""
    return HELPER_FILE.read_text(encoding="utf-8")


def helper_version() -> str:
    """The shipped helper's version (its CONST tcHelperVersion, as the RAPID reader reads it)."""
    declaration = read_module(HELPER_FILE).data.get(VERSION_SYMBOL)
    if declaration is None or not isinstance(declaration.value, str):
        raise RuntimeError(f"{HELPER_FILE}: no CONST string {VERSION_SYMBOL}")
    return declaration.value


def needed_signals(text: str | None = None) -> tuple[SignalNeed, ...]:
    """The signals of an EIO.cfg's EIO_SIGNAL section (default: the shipped one), in order."""
    text = IO_FILE.read_text(encoding="utf-8") if text is None else text
    needs = []
    for line in text.splitlines():
        if line.lstrip().startswith("#"):
            continue
        name = re.search(r'-Name\s+"([^"]+)"', line)
        kind = re.search(r'-SignalType\s+"([^"]+)"', line)
        if name is not None and kind is not None:
            signal = name.group(1)
            needs.append(SignalNeed(signal, kind.group(1).upper(), DEVICE_SIGNALS.get(signal, "")))
    return tuple(needs)
