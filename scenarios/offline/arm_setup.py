"""A file arm's home configuration and joint window, chosen in the virtual cell.

An arm read from its URDF or MJCF file comes with no home (all zeros: for most arms
stretched out level) and with the file's joint ranges (often +-360 deg), which admit every
branch of the inverse kinematics: the planner's solutions may flip the elbow or the wrist
between moves, and a tool may fold back into the forearm. A cell's safety configuration
fixes one branch; this module derives one from the arm's kinematics and the layout:

- **home**: the flange pointing down above the object's nominal place, the tools' length and
  a clearance above its top (lower and nearer the arm if it does not reach), elbow up, the
  wrist away from its singularity, and the arm (bare and with the laser) clear of the table,
  the object, the rack and the fixtures in the virtual cell;
- **joint window** around home, each joint bounded by what keeps the branch, shrunk by a
  margin: joint 1 one turn (home +-180 deg); joint 2 the upper arm above the shoulder;
  joint 3 between the elbow's stretched and folded singularities; joint 5 between the
  wrist's singularities (axes 4 and 6 aligned); joints 4 and 5 where no tool in hand comes
  within 5 mm of the forearm or the upper arm; joint 6 one turn each way. All within the
  file's ranges.

Homes come one per branch (the upper arm leaning towards the flange or not, the wrist on
one side or the other), best first: the window keeps the home's branch, and a job whose
rack slots, scan passes or transits lie outside it tries the next (scenarios.jobs.job_plan).

Each bound is found by sweeping its joint alone (the others at home) through the file's
range with the arm's own forward kinematics and the virtual cell's geometry (the tools'
bodies, the arm's link capsules): no table of arm types. The window is a box: a pose with
two joints near their bounds at once may still bring a tool against the forearm, which the
virtual cell's checks of every planned move (and the real cell's motion supervision) see,
as they see any other contact. A file arm with `home_deg` or `limits_deg` in its cell keeps
those.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from cell import Kinematics
from cell.arm_file import motion_axis
from cell.virtual import VirtualCell

#: Sweep step [rad] of the joint-window bounds.
_STEP = np.deg2rad(1.0)
#: Margin [rad] kept inside a singular bound (elbow, wrist).
SINGULAR_MARGIN_RAD = float(np.deg2rad(5.0))
#: The narrowest joint window [rad] a home may leave a joint.
MIN_WINDOW_RAD = float(np.deg2rad(20.0))
#: The gap [m] a tool in hand keeps from the arm's upper arm and forearm (the cell's own
#: geometry: the tools' bodies and the file arm's link capsules).
TOOL_ARM_GAP_M = 0.005
#: The arm's links a tool in hand must keep clear of (the flange's own links, 5 and 6,
#: carry it).
_FOLD_LINKS = frozenset({"link1", "link2", "link3", "link4"})
#: The tools' length [m] (the screwer's TCP, the longest): home's flange is this and a
#: clearance above the object's top.
TOOLS_LENGTH_M = 0.2
#: Clearance [m] the arm at home keeps from everything in the virtual cell.
HOME_CLEARANCE_M = 0.02


@dataclass(frozen=True, eq=False)
class ArmSetup:
    """What the cell chose for a file arm.

    Attributes:
        q_home: (6,) the home configuration [rad].
        lower, upper: (6,) the joint window [rad], within the file's ranges.
        bounds: per joint, what bounds its window (for the run's log).
        p_world_flange: (3,) where home puts the flange [m].
    """

    q_home: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    bounds: tuple[str, ...]
    p_world_flange: np.ndarray

    def describe(self) -> str:
        """One paragraph: the home and the window in degrees, and what bounds each joint."""
        home = ", ".join(f"{v:.0f}" for v in np.rad2deg(self.q_home))
        window = "; ".join(
            f"j{k + 1} {np.rad2deg(lo):.0f}..{np.rad2deg(hi):.0f} ({why})"
            for k, (lo, hi, why) in enumerate(zip(self.lower, self.upper, self.bounds, strict=True))
        )
        p = ", ".join(f"{v:.2f}" for v in self.p_world_flange)
        return (
            f"home [{home}] deg (flange at [{p}] m, pointing down, elbow up); joint window [deg]: "
            f"{window}"
        )


class ArmSetupError(ValueError):
    """No home or joint window satisfies the cell (the message names the keys to give)."""


# -- the arm's points, as the sweeps see them --------------------------------------------------
class _Arm:
    """The arm's kinematics with its joints' local axes, and its virtual cell, for the
    sweeps."""

    def __init__(self, kin: Kinematics, cell: VirtualCell) -> None:
        self.kin = kin
        self.cell = cell
        self._axes = [np.zeros(3)] + [motion_axis(kin.model, j) for j in range(1, 7)]

    def frames(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Origins (7, 3) and unit axes (7, 3) of joints 1..6 in the world at q (row 0
        unused)."""
        model, data = self.kin.model, self.kin.data
        pin.forwardKinematics(model, data, np.asarray(q, dtype=float))
        origins = np.zeros((7, 3))
        axes = np.zeros((7, 3))
        for j in range(1, 7):
            origins[j] = data.oMi[j].translation
            axes[j] = data.oMi[j].rotation @ self._axes[j]
        return origins, axes

    # The measures that bound the window (each depends on one joint, the others held).
    def stretch(self, q: np.ndarray) -> float:
        """Distance [m] from the shoulder (joint 2) to the wrist (joint 4): extreme where
        the elbow is stretched or folded."""
        o, _ = self.frames(q)
        return float(np.linalg.norm(o[4] - o[2]))

    def wrist_sine(self, q: np.ndarray) -> float:
        """Signed sine between the axes of joints 4 and 6 about joint 5's axis: zero where
        the wrist is singular."""
        _, a = self.frames(q)
        return float(np.cross(a[4], a[6]) @ a[5])

    def upper_arm_rise(self, q: np.ndarray) -> float:
        """Height [m] of the elbow (joint 3) above the shoulder (joint 2)."""
        o, _ = self.frames(q)
        return float(o[3, 2] - o[2, 2])

    def elbow_height(self, q: np.ndarray) -> float:
        """Height [m] of the elbow above the line from the shoulder to the wrist, in the
        vertical plane through that line: positive with the elbow up."""
        o, _ = self.frames(q)
        u = (o[4] - o[2]) / max(float(np.linalg.norm(o[4] - o[2])), 1e-9)
        up = np.array([0.0, 0.0, 1.0]) - u[2] * u
        n = float(np.linalg.norm(up))
        return 0.0 if n < 1e-6 else float((o[3] - o[2]) @ up) / n

    def tools_clear(self, q: np.ndarray) -> bool:
        """Whether each tool, in hand at q, keeps TOOL_ARM_GAP_M from the arm's upper arm
        and forearm in the virtual cell."""
        cell = self.cell
        cell.set_joints(q)
        try:
            for tool in cell.tools:
                cell.set_tool(tool)
                if any(c.other in _FOLD_LINKS for c in cell.contacts(TOOL_ARM_GAP_M)):
                    return False
        finally:
            cell.set_tool(None)
        return True


# -- the window -----------------------------------------------------------------------------------
def _sweep(
    arm: _Arm, q: np.ndarray, k: int, measure: Callable[[np.ndarray], float]
) -> tuple[np.ndarray, np.ndarray, int]:
    """Joint k's values over the file's range (home among them) and `measure` at each, the
    other joints at q; and home's index."""
    lo, hi = float(arm.kin.lower[k]), float(arm.kin.upper[k])
    # Steps of _STEP from home both ways, and the file's ends (home may sit on one).
    grid = np.unique(np.r_[lo, np.arange(q[k], lo, -_STEP), np.arange(q[k], hi, _STEP), hi])
    home = int(np.argmin(np.abs(grid - q[k])))
    values = np.array([measure(np.r_[q[:k], v, q[k + 1 :]]) for v in grid])
    return grid, values, home


def _run(ok: np.ndarray, home: int) -> tuple[int, int]:
    """First and last index of the run of True in `ok` that holds `home`."""
    lo = hi = home
    while lo > 0 and ok[lo - 1]:
        lo -= 1
    while hi < len(ok) - 1 and ok[hi + 1]:
        hi += 1
    return lo, hi


def _bounded(grid: np.ndarray, lo: int, hi: int, shrink: float) -> tuple[float, float]:
    """grid[lo], grid[hi], each moved in by `shrink` [rad] where it is not the file's end."""
    return (
        float(grid[lo]) + (shrink if lo > 0 else 0.0),
        float(grid[hi]) - (shrink if hi < len(grid) - 1 else 0.0),
    )


def joint_window(
    kin: Kinematics, q_home: np.ndarray, cell: VirtualCell
) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """The joint window (lower, upper (6,) [rad]) around `q_home` that keeps its branch, and
    what bounds each joint (see the module's docstring); the tools' clearance from the arm
    asked of its virtual cell `cell`."""
    arm = _Arm(kin, cell)
    q = np.asarray(q_home, dtype=float)
    lower, upper = kin.lower.copy(), kin.upper.copy()
    lower[0], upper[0] = max(lower[0], q[0] - np.pi), min(upper[0], q[0] + np.pi)
    lower[5], upper[5] = max(lower[5], q[5] - 2 * np.pi), min(upper[5], q[5] + 2 * np.pi)
    grid, rise, h = _sweep(arm, q, 1, arm.upper_arm_rise)
    lower[1], upper[1] = _bounded(grid, *_run(rise >= 0.0, h), 0.0)
    grid, stretch, h = _sweep(arm, q, 2, arm.stretch)
    slope = np.sign(np.diff(stretch))
    # Between the nearest extremes of the stretch: the slope keeps its sign on each side.
    same = np.r_[True, slope[1:] * slope[:-1] >= 0, True]
    lower[2], upper[2] = _bounded(grid, *_run(same, h), SINGULAR_MARGIN_RAD)
    # Joint 5: off the wrist's singularity, and the tools clear of the forearm (folded
    # back, a tool on a wrist that stays off its singularity can still meet the forearm).
    grid, sine, h = _sweep(arm, q, 4, arm.wrist_sine)
    lower[4], upper[4] = _bounded(grid, *_run(np.sign(sine) == np.sign(sine[h]), h),
                                  SINGULAR_MARGIN_RAD)  # fmt: skip
    grid, clear, h = _sweep(arm, q, 4, arm.tools_clear)
    clear_lo, clear_hi = _bounded(grid, *_run(clear > 0.0, h), 0.0)
    lower[4], upper[4] = max(lower[4], clear_lo), min(upper[4], clear_hi)
    grid, clear, h = _sweep(arm, q, 3, arm.tools_clear)
    lower[3], upper[3] = _bounded(grid, *_run(clear > 0.0, h), 0.0)
    narrow = np.flatnonzero(upper - lower < MIN_WINDOW_RAD)
    if narrow.size:
        raise ArmSetupError(
            f"the home {np.round(np.rad2deg(q), 1).tolist()} deg leaves joint(s) "
            f"{(narrow + 1).tolist()} less than {np.rad2deg(MIN_WINDOW_RAD):.0f} deg of room "
            "in its branch; give another home (cell.robot.home_deg) or the joint window "
            "(cell.robot.limits_deg)"
        )
    reasons = (
        "one turn about home",
        "upper arm above the shoulder",
        "elbow between stretched and folded",
        "tools clear of the forearm",
        "wrist off its singularity",
        "a turn each way",
    )
    whole = (lower <= kin.lower) & (upper >= kin.upper)  # nothing narrowed it
    bounds = tuple("the file's range" if w else r for w, r in zip(whole, reasons, strict=True))
    return lower, upper, bounds


# -- home -----------------------------------------------------------------------------------------
#: Where home's flange is tried, in turn: the fraction of the way from the mount to the
#: object's centre (horizontally) and the height above the object's top beyond the tools'
#: length [m].
_HOME_FRACTIONS = (1.0, 0.8, 0.6, 0.4)
_HOME_HEIGHTS_M = (0.1, 0.05, 0.2, 0.3, 0.0)
#: Turns [rad] of the flange about its (vertical) axis tried at each place.
_HOME_YAWS = tuple(np.deg2rad([0.0, 90.0, 180.0, 270.0]))
#: Random IK starts per pose (deterministic): each converged one is a candidate branch.
_HOME_STARTS = 24


def _down(p: np.ndarray, yaw: float) -> np.ndarray:
    """(4, 4) the flange at p, its z axis pointing down, its x axis at `yaw` [rad]."""
    c, s = np.cos(yaw), np.sin(yaw)
    T = np.eye(4)
    T[:3, :3] = np.array([[c, s, 0.0], [s, -c, 0.0], [0.0, 0.0, -1.0]])
    T[:3, 3] = p
    return T


def _candidates(arm: _Arm, T: np.ndarray) -> list[np.ndarray]:
    """IK solutions for the flange at T from random starts, each joint at its turn nearest
    zero, with the elbow up, the upper arm above the shoulder and the wrist well off its
    singularity (more than 15 deg)."""
    kin = arm.kin
    rng = np.random.default_rng(0)
    found: list[np.ndarray] = []
    for _ in range(_HOME_STARTS):
        result = kin.ik(T, kin.random_configuration(rng), extra_seeds=0, max_iterations=80)
        if not result.success:
            continue
        q = kin.nearest_turns(result.q, np.zeros(6))  # each joint's turn nearest zero
        if any(np.allclose(q, f, atol=1e-3) for f in found):
            continue
        if (
            arm.elbow_height(q) > 0.02
            and arm.upper_arm_rise(q) >= 0.0
            and abs(arm.wrist_sine(q)) > np.sin(np.deg2rad(15.0))
            and arm.tools_clear(q)
        ):
            found.append(q)
    return found


def _clear(cell: VirtualCell, q: np.ndarray) -> bool:
    """Whether the arm at q, bare and with the laser, keeps HOME_CLEARANCE_M from everything
    in the virtual cell (the table at 0)."""
    cell.set_table(0.0)
    cell.set_joints(q)
    for tool in (None, "laser"):
        cell.set_tool(tool)
        if cell.contacts(HOME_CLEARANCE_M):
            return False
    cell.set_tool(None)
    return True


def _rank(arm: _Arm, q: np.ndarray) -> tuple[bool, float]:
    """How a home candidate ranks (larger first): the upper arm leaning towards the flange
    (the arm faces its work, not reaching back over its shoulder), then how far q is from
    the branch's edges: the smaller of the wrist's sine and the elbow's height over the
    shoulder-to-wrist distance (each 0 at a singular pose)."""
    o, _ = arm.frames(q)
    towards = (o[3, :2] - o[2, :2]) @ (arm.kin.fk(q)[:2, 3] - o[2, :2]) > 0.0
    return bool(towards), min(
        abs(arm.wrist_sine(q)), arm.elbow_height(q) / max(arm.stretch(q), 1e-9)
    )


def arm_setups(
    kin: Kinematics,
    cell: VirtualCell,
    p_world_object: np.ndarray,
    top_z_m: float,
) -> Iterator[ArmSetup]:
    """Homes and joint windows for the arm of `kin` (the file's ranges) in `cell` (its
    virtual cell, the object at its nominal pose), best first: the flange pointing down
    above the object's centre `p_world_object` (3,) [m], the tools' length and a clearance
    above its top `top_z_m` [m], tried nearer the arm and at other heights where it does not
    reach; at each place, the branches with the upper arm leaning towards the flange first,
    then the farthest from the elbow's and the wrist's singularities; one per branch (the
    upper arm's lean and the wrist's side), since the window keeps the home's branch and a
    job's poses may need another. Lazy: a job takes the next only if the one before cannot
    do it."""
    arm = _Arm(kin, cell)
    mount = np.asarray(kin.model.jointPlacements[1].translation, dtype=float)
    given: set[tuple[bool, bool]] = set()
    for fraction in _HOME_FRACTIONS:
        xy = mount[:2] + fraction * (np.asarray(p_world_object[:2]) - mount[:2])
        for height in _HOME_HEIGHTS_M:
            p = np.r_[xy, top_z_m + TOOLS_LENGTH_M + height]
            clear = [
                q for yaw in _HOME_YAWS for q in _candidates(arm, _down(p, yaw)) if _clear(cell, q)
            ]
            for q in sorted(clear, key=lambda c: _rank(arm, c), reverse=True):
                # One home per branch (the upper arm's lean, the wrist's side): the next
                # home a job tries is another way of holding the arm, not the same one.
                branch = (_rank(arm, q)[0], arm.wrist_sine(q) > 0.0)
                if branch in given:
                    continue
                try:
                    lower, upper, bounds = joint_window(kin, q, cell)
                except ArmSetupError:
                    continue  # a branch with no room for one of its joints
                given.add(branch)
                yield ArmSetup(q, lower, upper, bounds, p)


def choose_arm_setup(
    kin: Kinematics,
    cell: VirtualCell,
    p_world_object: np.ndarray,
    top_z_m: float,
) -> ArmSetup:
    """The best of `arm_setups`; raises ArmSetupError when no place gives a clear home."""
    for setup in arm_setups(kin, cell, p_world_object, top_z_m):
        return setup
    raise ArmSetupError(no_home_message())


def no_home_message() -> str:
    """Why a file arm has no home, and the keys that would give it one."""
    places = len(_HOME_FRACTIONS) * len(_HOME_HEIGHTS_M)
    return (
        f"no clear home with the flange pointing down above the object (tried {places} "
        "places over and towards it): the arm does not reach over the object from its "
        "mount; move the arm nearer (cell.robot.mount_xyz) or the object (cell.object."
        "placement.xy_m), or give the arm's home and joint window (cell.robot.home_deg, "
        "cell.robot.limits_deg)"
    )
