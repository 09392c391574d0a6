"""The TCP check of a pointed tool after it is locked, at the cell's light beam (a TCP check
station such as ABB's BullsEye): is the tool seated where its tooldata says?

The pointer, held vertical, crosses the beam sideways at four spins about its axis (-90, 0,
90, 180 degrees). Where the beam breaks and clears, the controller reads the TCP from its
encoders; the middle of the two is where it believes the pointer was when the beam met it.
The difference from the beam is the pointer's sideways offset plus the arm's own error
there; turned half a turn, the offset changes sign and the arm's error does not, so half the
difference of opposite spins is the tool's offset, free of the arm's error.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from cell import Controller, SupervisionError
from scenarios.offline.moves import change_tool_safely
from scenarios.results.verification import TcpCheck

#: Tools with a pointer the beam can see: the pointer's radius [m] and how far above the TCP
#: the beam crosses it [m] (the screwer's pointer: a 3 mm ball-ended rod, its TCP the ball's
#: centre).
POINTERS = {"screwer": (0.003, 0.012)}
#: Sideways travel of a sweep, each side of the beam [m], and its speed [m/s].
SWEEP_M = 0.015
SWEEP_SPEED_M_S = 0.01
#: A tool seated farther off its tooldata than this is refused [m] (the TCP's own error and
#: the check's are a few tenths of a millimetre at most).
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


def check_tcp(
    controller: Controller, tolerance_m: float = TOLERANCE_M, attempt: int = 0
) -> TcpCheck | None:
    """Check the tool in hand at the beam (see the module) against `tolerance_m` [m]; None
    for a tool without a pointer."""
    tool = controller.tool_in_hand
    if tool not in POINTERS:
        return None
    _radius, above = POINTERS[tool]
    p_from, p_to = controller.beam_line_base
    centre = (p_from + p_to) / 2.0
    across = np.cross(p_to - p_from, [0.0, 0.0, 1.0])
    across /= np.linalg.norm(across)
    low = centre - [0.0, 0.0, above]  # the TCP, the beam crossing the rod above it
    moved = {}
    for spin in SPINS_DEG:
        controller.move_tcp(_pose(spin, low - SWEEP_M * across))
        samples = controller.sweep_beam(_pose(spin, low + SWEEP_M * across), SWEEP_SPEED_M_S)
        seen = [
            float((controller.kinematics.fk(q) @ controller.T_flange_tcp())[:3, 3] @ across)
            for q, broken in samples
            if broken
        ]
        # How far the real pointer is from where the controller believes it, across.
        moved[spin] = float(centre @ across) - (min(seen) + max(seen)) / 2 if seen else np.inf
    controller.move_tcp(_pose(0.0, low - SWEEP_M * across + [0.0, 0.0, 0.1]))
    # Across the beam, spin s sees sin(s) x + cos(s) y of the offset (x, y) in the tool
    # frame (the tool axis down, as _pose holds it), plus the arm's error.
    ox = (moved[90.0] - moved[-90.0]) / 2.0
    oy = (moved[0.0] - moved[180.0]) / 2.0
    return TcpCheck(tool, (ox, oy), tolerance_m, attempt)


def checked_tool(
    controller: Controller,
    tool: str,
    say: Callable[[str], None],
    detect: Callable[[str, str, str], None],
    tolerance_m: float = TOLERANCE_M,
) -> tuple[TcpCheck, ...]:
    """Change to `tool` and check it at the beam against `tolerance_m` [m]: a tool seated
    off its tooldata is put back and taken again once (`detect(code, message, action)`
    hears of it); still off, the cell stops (SupervisionError "tcp_check"). Returns the
    checks made (none for a tool without a pointer)."""
    checks: list[TcpCheck] = []
    for attempt in range(2):
        change_tool_safely(controller, tool)
        check = check_tcp(controller, tolerance_m, attempt)
        if check is None:
            return ()
        checks.append(check)
        if check.ok:
            say(f"TCP check: {check.summary()}")
            return tuple(checks)
        if attempt == 0:
            detect("tcp_check", check.summary(), "re-seated the tool")
            controller.move_joints(controller.q_home)
            controller.return_tool(check.T_flange_tool if np.isfinite(check.off_m) else None)
    assert check is not None  # a check that could not be made returned above
    detect("tcp_check", check.summary(), "stopped")
    raise SupervisionError("tcp_check", f"TCP check: {check.summary()}, after re-seating it")
