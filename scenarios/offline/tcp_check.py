"""The TCP check of a pointed tool after it is locked, at the cell's light beam (a TCP check
station such as ABB's BullsEye): is the tool seated where it should be?

The pointer, held vertical, crosses the beam sideways at four spins about its axis (-90, 0,
90, 180 degrees). Where the beam breaks and clears, the controller reads the joints; the TCP
at the middle of the two is where it believes the pointer was when the beam met it. The
difference from the beam is the pointer's sideways offset plus the arm's own error there;
turned half a turn, the offset changes sign and the arm's error mostly does not, so half the
difference of opposite spins is the tool's offset. What the arm's error changes between two
turns of the wrist stays in it: on a calibrated IRB 2400 a tenth of a millimetre, on a UR5
several tenths.

That part of the reading is the same every time the same cell crosses the beam the same way:
a reading taken when the cell was commissioned, with each tool seated by hand and known good
(scenarios.offline.commissioning), is the reference that later checks difference against, as
a BullsEye station's. The difference is then the seat's change since commissioning, measured
to the cell's repeatability (its scatter over the commissioning's readings). Without a
reference, the reading's uncertainty holds the calibrated arm's accuracy (a data-sheet
figure), and a tolerance finer than K_SIGMA times that is checked to that much only.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from cell import Controller, SupervisionError
from scenarios.program.tool_change import change_tool_safely
from scenarios.results.beam import BeamCrossing, BeamReading, as_joints
from scenarios.results.verification_result import TcpCheck

#: Tools with a pointer the beam can see: the pointer's radius [m] and how far above the TCP
#: the beam crosses it [m] (the screwer's pointer: a 3 mm ball-ended rod, its TCP the ball's
#: centre).
POINTERS = {"screwer": (0.003, 0.012)}
#: Sideways travel of a sweep, each side of the beam [m], and its speed [m/s].
SWEEP_M = 0.015
SWEEP_SPEED_M_S = 0.01
#: A tool seated farther off than this is refused when the job has no goal [m].
TOLERANCE_M = 7.5e-4
SPINS_DEG = (-90.0, 0.0, 90.0, 180.0)


def _pose(spin_deg: float, p: np.ndarray) -> np.ndarray:
    """The TCP pose: the tool axis down, turned `spin_deg` about it, at `p` (3,)."""
    c, s = np.cos(np.deg2rad(spin_deg)), np.sin(np.deg2rad(spin_deg))
    down = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])
    T = np.eye(4)
    T[:3, :3] = down @ np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    T[:3, 3] = p
    return T


def _beam_axes(controller: Controller) -> tuple[np.ndarray, np.ndarray]:
    """The beam's middle (3,) [m] and the horizontal direction across it (3,)."""
    p_from, p_to = controller.beam_line_base
    across = np.cross(p_to - p_from, [0.0, 0.0, 1.0])
    return (p_from + p_to) / 2.0, across / np.linalg.norm(across)


def read_beam(controller: Controller, sweep_m: float = SWEEP_M) -> BeamReading | None:
    """Sweep the tool in hand through the beam at each of SPINS_DEG; None for a tool without
    a pointer; each sweep from `sweep_m` [m] before the beam to as far after it. The arm
    ends 0.1 m above the beam's near side. The sweeps run on the
    controller's nominal arm whether or not it has a calibrated one (as a check station's
    fixed routine does), so that the cell crosses the beam the same way at every reading."""
    tool = controller.tool_in_hand
    if tool not in POINTERS:
        return None
    calibrated = controller.absolute_accuracy
    controller.set_absolute_accuracy(None)
    try:
        return _sweeps(controller, tool, sweep_m)
    finally:
        controller.set_absolute_accuracy(calibrated)


def _sweeps(controller: Controller, tool: str, sweep_m: float) -> BeamReading:
    """The sweeps of `read_beam`."""
    _radius, above = POINTERS[tool]
    centre, across = _beam_axes(controller)
    low = centre - [0.0, 0.0, above]  # the TCP, the beam crossing the rod above it
    crossings = []
    for spin in SPINS_DEG:
        controller.move_tcp(_pose(spin, low - sweep_m * across))
        samples = controller.sweep_beam(_pose(spin, low + sweep_m * across), SWEEP_SPEED_M_S)
        broken = [q for q, is_broken in samples if is_broken]
        if broken:
            crossings.append(BeamCrossing(spin, as_joints(broken[0]), as_joints(broken[-1])))
    controller.move_tcp(_pose(0.0, low - sweep_m * across + [0.0, 0.0, 0.1]))
    return BeamReading(tool, SPINS_DEG, tuple(crossings))


def beam_offset(controller: Controller, reading: BeamReading) -> np.ndarray:
    """(2,) [m] the pointer's sideways offset (x, y) in the tool frame that `reading` shows,
    from its joints with the controller's kinematics now and the tool's tooldata; inf where a
    sweep missed the beam."""
    if not reading.complete:
        return np.full(2, np.inf)
    centre, across = _beam_axes(controller)
    T_flange_tcp = controller.T_flange_tcp(reading.tool)
    kinematics = controller.kinematics

    def seen(q: tuple[float, ...]) -> float:
        return float((kinematics.fk(np.asarray(q)) @ T_flange_tcp)[:3, 3] @ across)

    # How far the real pointer is from where the controller believes it, across the beam.
    moved = {
        c.spin_deg: float(centre @ across) - (seen(c.q_first) + seen(c.q_last)) / 2.0
        for c in reading.crossings
    }
    # Across the beam, spin s sees sin(s) x + cos(s) y of the offset (x, y) in the tool
    # frame (the tool axis down, as _pose holds it), plus the arm's error.
    return np.array([(moved[90.0] - moved[-90.0]) / 2.0, (moved[0.0] - moved[180.0]) / 2.0])


def reference_offset(
    controller: Controller, references: Sequence[BeamReading], repeatability_m: float
) -> tuple[np.ndarray, float]:
    """The commissioning readings' mean offset (2,) [m], evaluated as a check's is now, and
    one reading's standard deviation per axis [m]: their scatter (pooled over x and y), but
    at least the arm's pose repeatability `repeatability_m` [m] (data sheet)."""
    offsets = np.array([beam_offset(controller, r) for r in references])
    mean = offsets.mean(axis=0)
    if len(offsets) < 2:
        return mean, repeatability_m
    scatter = float(np.sqrt(((offsets - mean) ** 2).sum() / (2 * (len(offsets) - 1))))
    return mean, max(scatter, repeatability_m)


def check_tcp(
    controller: Controller,
    tolerance_m: float = TOLERANCE_M,
    attempt: int = 0,
    references: Sequence[BeamReading] = (),
    priors: tuple[float, float] = (2.0e-5, 1.5e-4),
) -> TcpCheck | None:
    """Check the tool in hand at the beam (see the module) against `tolerance_m` [m]; None
    for a tool without a pointer. `references`: the tool's commissioning readings (none: the
    reading against the tooldata); `priors`: the arm's pose repeatability and the calibrated
    arm's accuracy, per axis [m] (data sheets), the floor of the reading's uncertainty and
    what an unreferenced reading holds of the arm's error."""
    reading = read_beam(controller)
    if reading is None:
        return None
    offset = beam_offset(controller, reading)
    repeatability_m, accuracy_m = priors
    if references:
        reference, sigma = reference_offset(controller, references, repeatability_m)
        sigma *= np.sqrt(1.0 + 1.0 / len(references))  # the reference's own mean's share
        offset = offset - reference
    else:
        sigma = float(np.hypot(repeatability_m, accuracy_m))
    x, y = (float(v) for v in offset)
    return TcpCheck(
        reading.tool, (x, y), tolerance_m, attempt, float(sigma), referenced=bool(references)
    )


def checked_tool(
    controller: Controller,
    tool: str,
    say: Callable[[str], None],
    detect: Callable[[str, str, str], None],
    checked: Callable[[TcpCheck], None],
    check: Callable[[Controller, int], TcpCheck | None],
) -> tuple[TcpCheck, ...]:
    """Change to `tool` and `check(controller, attempt)` it at the beam; each check made is
    handed to `checked` as it is made. A tool called off is put back and taken again once
    (`detect(code, message, action)` hears of it); still off, the cell stops
    (SupervisionError "tcp_check"). A tool seated but shifted (`TcpCheck.corrected`) is
    told to `detect` too, its TCP corrected by the reading. Returns the checks made (none
    for a tool without a pointer)."""
    checks: list[TcpCheck] = []
    for attempt in range(2):
        change_tool_safely(controller, tool)
        made = check(controller, attempt)
        if made is None:
            return ()
        checks.append(made)
        checked(made)
        if made.ok:
            corrected = "; its TCP corrected by the reading" if made.corrected else ""
            say(f"TCP check: {made.summary()}{corrected}")
            if made.corrected:
                detect("tcp_check", made.summary(), "corrected the TCP by the reading")
            return tuple(checks)
        if attempt == 0:
            detect("tcp_check", made.summary(), "re-seated the tool")
            controller.move_joints(controller.q_home)
            seated_at = made.T_flange_tool if np.isfinite(made.off_m) else None
            controller.return_tool(seated_at)
    detect("tcp_check", checks[-1].summary(), "stopped")
    raise SupervisionError("tcp_check", f"TCP check: {checks[-1].summary()}, after re-seating it")
