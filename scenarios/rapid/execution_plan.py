"""A RAPID program's execution plan: each move resolved for the controller's nominal arm
(`PlannedMove`) and the program as a whole (`ExecutionPlan`), what scenarios.rapid.planner
makes and scenarios.rapid.executor runs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scenarios.rapid.confdata import Conf


@dataclass(frozen=True, eq=False)
class PlannedMove:
    """One move resolved for the nominal arm.

    Attributes:
        instruction: "MoveJ", "MoveL" or "MoveAbsJ"; target: the target as written.
        line, routine: where the move is written.
        tooldata, wobj: the tooldata's and work object's names ("tool0", "wobj0" if none).
        T_flange_tcp: (4, 4) the tooldata's TCP in the flange frame [m].
        T_base_oframe: (4, 4) the work object's object frame in the base frame [m].
        T_base_tcp: (4, 4) the target TCP pose in the base frame [m].
        conf: the confdata honoured (None: MoveAbsJ, or configuration monitoring off).
        q: (6,) the joints at the end of the move [rad].
        table_position_m: the table during the move [m] (None: left where it is).
        v_tcp_m_s, v_ori_rad_s: the programmed speeds after VelSet.
        speed_fraction: the fraction of the joints' speed limits of a joint move.
        stop: a stop point (fine, \\Inpos); touch: a MoveL to a stop point.
        source: the file (or module) the move is written in.
        stop_time_s: how long the arm stands still at a stop point whose \\Inpos is a
            stoppointdata of type stoptime [s]; None: the controller settles as at `fine`.
        supervised: the motion supervision watches the move (False after MotionSup \\Off).
    """

    instruction: str
    target: str
    line: int
    routine: str
    tooldata: str
    wobj: str
    T_flange_tcp: np.ndarray
    T_base_oframe: np.ndarray
    T_base_tcp: np.ndarray
    conf: Conf | None
    q: np.ndarray
    table_position_m: float | None
    v_tcp_m_s: float
    v_ori_rad_s: float
    speed_fraction: float
    stop: bool
    touch: bool
    source: str = ""
    stop_time_s: float | None = None
    supervised: bool = True


@dataclass(frozen=True, eq=False)
class ExecutionPlan:
    """A module ready to run: the file it came from (a task's folder, or the file of the
    module that holds main), its name, the compensation it states
    (`! compensation: <word>`, else "nominal"), the cell's tool it needs in hand (None: the
    program moves the flange only), the start configuration q_start (6,) [rad] and the
    flange pose there T_base_flange_start (4, 4) (the kinematics it was planned with), the
    moves, and the instructions run without effect ("line N: Name")."""

    source: str
    module: str
    compensation: str
    tool: str | None
    q_start: np.ndarray
    T_base_flange_start: np.ndarray
    moves: tuple[PlannedMove, ...]
    skipped: tuple[str, ...]

    @property
    def touches(self) -> tuple[PlannedMove, ...]:
        return tuple(m for m in self.moves if m.touch)
