"""The tool changer: weld equalities switched between a tool's rack slot and the flange.

On lock, the flange weld of the tool seated against the flange is activated at the CURRENT
relative pose (written into `eq_data` first) and its rack weld released; on unlock at the rack,
the reverse, the rack's seat centring the tool in its slot. A tool is never left floating:
unlocking away from the tool's slot is refused.
"""

from __future__ import annotations

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from cell.cell_errors import ToolChangerError
from cell.sim.faults import FaultInjector
from cell.sim.simulation import Simulation
from registration.rigid import R_to_quat_wxyz, invert, pose_error

#: The changer engages only when the tool's interface is this close to the flange [m], [rad].
CAPTURE_DISTANCE_M = 3e-3
CAPTURE_ANGLE_RAD = 0.02
#: Time [s] the changer takes to lock or release.
ACTUATION_TIME_S = 0.1


class ToolChanger:
    """Locks and releases tools in the physics of `sim`; `held` is the locked tool or None.
    A tool seats where the flange meets it, off by the changer's repeatability (`sigma_m`
    [m], `sigma_rad` [rad], Gaussian per axis, redrawn at every lock)."""

    def __init__(
        self,
        sim: Simulation,
        sigma_m: float = 0.0,
        sigma_rad: float = 0.0,
        rng: np.random.Generator | None = None,
    ) -> None:
        self.sim = sim
        self.held: str | None = None
        self.sigma_m = sigma_m
        self.sigma_rad = sigma_rad
        self.rng = rng or np.random.default_rng(0)
        self.faults: FaultInjector | None = None

    def _seat(self) -> np.ndarray:
        """(4, 4) how far a tool seats from where it met the flange (in the tool's frame)."""
        T = np.eye(4)
        if self.sigma_rad > 0.0:
            T[:3, :3] = Rotation.from_rotvec(self.rng.normal(0.0, self.sigma_rad, 3)).as_matrix()
        if self.sigma_m > 0.0:
            T[:3, 3] = self.rng.normal(0.0, self.sigma_m, 3)
        return T

    def _set_weld(
        self, eq: int, body1: int, body2: int, T_body1_shift: np.ndarray | None = None
    ) -> None:
        """Write body2's pose in body1's frame (moved by `T_body1_shift` in body1's frame) as
        the weld's relative pose, then activate it."""
        T_1_2 = invert(self.sim.body_T(body1)) @ self.sim.body_T(body2)
        if T_body1_shift is not None:
            T_1_2 = invert(T_body1_shift) @ T_1_2
        self.sim.model.eq_data[eq, 3:6] = T_1_2[:3, 3]
        self.sim.model.eq_data[eq, 6:10] = R_to_quat_wxyz(T_1_2[:3, :3])
        self.sim.data.eq_active[eq] = 1

    def tool_at_flange(self) -> str | None:
        """The tool whose interface is within capture range of the flange, if any."""
        T_flange = self.sim.site_T(self.sim.flange_site)
        for name, body in self.sim.tool_body.items():
            dr, dp = pose_error(T_flange, self.sim.body_T(body))
            if dp <= CAPTURE_DISTANCE_M and dr <= CAPTURE_ANGLE_RAD:
                return name
        return None

    def lock(self) -> str:
        """Lock the tool seated against the flange; returns its name."""
        mujoco.mj_forward(self.sim.model, self.sim.data)
        if self.held is not None:
            raise ToolChangerError(
                f"cannot lock: the changer already holds the {self.held!r} tool; unlock it first"
            )
        name = self.tool_at_flange()
        if name is None:
            raise ToolChangerError(
                "cannot lock: no tool is seated against the flange (within "
                f"{CAPTURE_DISTANCE_M * 1e3:g} mm and {CAPTURE_ANGLE_RAD:g} rad)"
            )
        sim = self.sim
        seat = self._seat()
        fault = None if self.faults is None else self.faults.armed("tool_lock_fail")
        if fault is not None and self.faults is not None and fault.option in (None, name):
            if fault.amount == 0.0:  # the fingers do not engage: the tool stays in its slot
                self.faults.fire("tool_lock_fail", f"the {name} tool did not lock")
                sim.settle(ACTUATION_TIME_S)
                return name
            side = self.faults.rng.normal(size=2)
            shift = np.eye(4)
            shift[:2, 3] = fault.amount * side / np.linalg.norm(side)
            seat = seat @ shift
            self.faults.fire(
                "tool_lock_fail",
                f"the {name} tool locked {fault.amount * 1e3:.1f} mm off its seat",
            )
        self._set_weld(sim.flange_eq[name], sim.tool_body[name], sim.link6, seat)
        sim.data.eq_active[sim.rack_eq[name]] = 0
        self.held = name
        sim.settle(ACTUATION_TIME_S)
        return name

    def unlock(self) -> str:
        """Release the held tool into its rack slot; returns its name."""
        if self.held is None:
            raise ToolChangerError("cannot unlock: the changer holds no tool")
        sim, name = self.sim, self.held
        mujoco.mj_forward(sim.model, sim.data)
        dr, dp = pose_error(sim.site_T(sim.slot_site[name]), sim.body_T(sim.tool_body[name]))
        if dp > CAPTURE_DISTANCE_M or dr > CAPTURE_ANGLE_RAD:
            raise ToolChangerError(
                f"cannot unlock the {name!r} tool here: it is {dp * 1e3:.3g} mm and {dr:.3g} rad "
                "from its rack slot and would fall; move it into the slot first"
            )
        # The rack's seat (locating cones) centres the tool in its slot, wherever within the
        # capture range the arm let it go.
        T_seat = sim.site_T(sim.slot_site[name])
        T_tool = sim.body_T(sim.tool_body[name])
        self._set_weld(
            sim.rack_eq[name], sim.tool_body[name], sim.rack_body, invert(T_tool) @ T_seat
        )
        sim.data.eq_active[sim.flange_eq[name]] = 0
        self.held = None
        sim.settle(ACTUATION_TIME_S)
        return name

    def tool_in_slot(self, name: str) -> bool:
        """Whether tool `name` is held by its rack weld (not on the flange)."""
        return bool(self.sim.data.eq_active[self.sim.rack_eq[name]]) and self.held != name


def flange_offset(sim: Simulation, name: str) -> np.ndarray:
    """(4, 4) pose of tool `name`'s frame in the flange frame, as welded now (truth)."""
    return invert(sim.site_T(sim.flange_site)) @ sim.body_T(sim.tool_body[name])
