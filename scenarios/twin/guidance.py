"""EGM guidance on the served controller: one control period of the arm following the
client's streamed references (EGMRunJoint, EGMRunPose with tool0 and wobj0), as the
controller's worker runs it while no program runs."""

from __future__ import annotations

import numpy as np

from cell import CellError, Controller, SupervisionError
from scenarios.twin.egm import EgmServer
from scenarios.twin.elog import EventLog

#: The controller's control period [s].
PERIOD_S = 0.004
#: A streamed reference older than this is not followed (the arm holds) [s].
STALE_S = 0.1


class Guidance:
    """The arm of `cell` following the references that come on `link`."""

    def __init__(self, cell: Controller, link: EgmServer, elog: EventLog) -> None:
        self.cell, self.link, self.elog = cell, link, elog

    def fresh(self) -> bool:
        """Whether a reference not older than STALE_S waits to be followed."""
        return self.link.fresh(STALE_S)

    def tick(self, q_ref: np.ndarray, motors_on: bool) -> np.ndarray:
        """One control period: head for the freshest reference (motors on), else hold at
        `q_ref` (6,) [rad]; returns the joints commanded now. A reference the arm cannot
        follow (a collision, a pose out of reach) is refused until the client sends another."""
        link, held = self.link, q_ref
        reference = link.reference(lambda T: self._solve(T, q_ref), STALE_S)
        if reference is not None and motors_on:
            q_ref = reference
        try:
            self.cell.servo(q_ref, PERIOD_S)
        except SupervisionError as exc:
            self.elog.add("collision", f"EGM: {exc}")
            link.refuse_until_new()
            return self.cell.read_joints()
        except CellError as exc:
            link.refuse_until_new()
            self.elog.add("egm", f"EGM reference refused: {exc}")
            return held
        return q_ref

    def _solve(self, T_base_flange: np.ndarray, q_ref: np.ndarray) -> np.ndarray:
        """The joints (6,) [rad] that put the flange at `T_base_flange` on the nominal arm,
        from the joints commanded now."""
        return self.cell.nominal_kinematics.solve(T_base_flange, q_ref, np.eye(4))
