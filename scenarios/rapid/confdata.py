"""A robtarget's confdata: which of the arm's inverse-kinematics solutions it asks for, and
how the planner finds that one.

A pose of a six-axis arm has up to eight solutions (shoulder in front of or behind axis 1,
elbow up or down, wrist flipped or not), and each wrist axis with more than one turn of range
repeats them by whole turns. ABB's confdata (cf1, cf4, cf6, cfx) names one: the quadrants of
axes 1, 4 and 6 (cfk = floor(qk / 90 deg), so that cf6 also counts the turns of axis 6) and
cfx, the branch bits as `scenarios.rapid.writer.configuration` defines them after ABB's table
of eight configurations: 4 = the wrist centre behind axis 1, 2 = the wrist centre below (on
the far side of) the lower arm, 1 = axis 5 negative.

All four are honoured, every cfx bit included: together they pick exactly one solution of a
pose (the bits pick the branch, the quadrants the turns), which is what a controller with
configuration monitoring on (ConfJ\\On, ConfL\\On, the default) moves to. One allowance:
an axis within `QUADRANT_BORDER_RAD` of its quadrant's border honours either neighbour,
and axis 5 within it of zero honours either sign. A target's confdata is computed from the
joints of the arm that planned it (the calibrated arm of a run, RobotStudio's model of the
arm), and the nominal arm's joints for the same pose differ by a few milliradians: near a
border the two can round to neighbouring quadrants without meaning another solution. The
shoulder and elbow bits are taken exactly (they change only through a singularity).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from cell import Kinematics
from scenarios.rapid.rapid_text import configuration

Conf = tuple[int, int, int, int]

#: A joint this close to a quadrant border [rad] honours the quadrants on both sides.
QUADRANT_BORDER_RAD = float(np.deg2rad(1.0))
#: Random seeds tried, in batches, when the nearest solution is in another configuration.
MAX_SEEDS = 48
_BATCH = 8
_SAME_Q_RAD = 1e-6


@dataclass(frozen=True, eq=False)
class ConfSolution:
    """The joints q (6,) [rad] in the asked configuration, or None; the configurations of
    every solution found (for the message when none is the one asked for); whether the pose
    is reachable at all, and the smallest residual [m] of the attempts when it is not."""

    q: np.ndarray | None
    found: tuple[Conf, ...]
    reachable: bool
    residual_m: float


def _quadrant_ok(angle: float, quadrant: int, border: float) -> bool:
    quarter = np.pi / 2
    return any(int(np.floor((angle + d) / quarter)) == quadrant for d in (0.0, border, -border))


def honours(
    kin: Kinematics, q: np.ndarray, conf: Conf, border_rad: float = QUADRANT_BORDER_RAD
) -> bool:
    """Whether joints q (6,) [rad] are in configuration `conf` (cf1, cf4, cf6, cfx), a joint
    within `border_rad` of a quadrant border (axis 5 of zero) honouring both sides."""
    actual = configuration(kin, q)
    if (actual[3] & 6) != (conf[3] & 6):
        return False
    wants_negative_5 = bool(conf[3] & 1)
    if (q[4] >= border_rad) if wants_negative_5 else (q[4] <= -border_rad):
        return False
    return all(_quadrant_ok(float(q[k]), conf[i], border_rad) for i, k in enumerate((0, 3, 5)))


class _Solutions:
    """Distinct solutions of one pose, each within the limits and checked by FK."""

    def __init__(self, kin: Kinematics, T_base_tcp: np.ndarray, T_flange_tcp: np.ndarray) -> None:
        self.kin = kin
        self.T = T_base_tcp
        self.T_tcp = T_flange_tcp
        self.items: list[np.ndarray] = []
        self.residual_m = np.inf

    def solve(self, seed: np.ndarray) -> np.ndarray | None:
        r = self.kin.ik(self.T, seed, self.T_tcp, extra_seeds=0)
        if not r.success:
            self.residual_m = min(self.residual_m, r.position_error_m)
            return None
        self.residual_m = 0.0
        self.add(r.q)
        return r.q

    def add(self, q: np.ndarray) -> None:
        kin = self.kin
        if np.any(q < kin.lower - 1e-9) or np.any(q > kin.upper + 1e-9):
            return
        if any(np.max(np.abs(q - other)) < _SAME_Q_RAD for other in self.items):
            return
        self.items.append(np.array(q, dtype=float))

    def expand(self, q: np.ndarray) -> None:
        """Add the solutions one turn (or several) of each joint away from q, and the flipped
        wrist (axes 4 and 6 half a turn on, axis 5 mirrored), refined by the IK (exact for a
        spherical wrist; a few iterations otherwise)."""
        kin = self.kin
        flipped = np.array(q, dtype=float)
        flipped[3] += np.pi if flipped[3] < 0 else -np.pi
        flipped[5] += np.pi if flipped[5] < 0 else -np.pi
        flipped[4] = -flipped[4]
        bases = [np.array(q, dtype=float)]
        refined = self.solve(flipped)
        if refined is not None:
            bases.append(refined)
        for base in bases:
            options = []
            for k in range(kin.nq):
                turns = [
                    base[k] + 2 * np.pi * n
                    for n in range(-3, 4)
                    if kin.lower[k] - 1e-9 <= base[k] + 2 * np.pi * n <= kin.upper[k] + 1e-9
                ]
                options.append(turns or [base[k]])
            for values in itertools.product(*options):
                self.add(np.array(values))


def solve_in_configuration(
    kin: Kinematics,
    T_base_tcp: np.ndarray,
    T_flange_tcp: np.ndarray,
    conf: Conf | None,
    q_near: np.ndarray,
    seed: int = 0,
) -> ConfSolution:
    """Joints that put the TCP (the flange times `T_flange_tcp`, 4 x 4) at `T_base_tcp`
    (4, 4) [m] in configuration `conf` (None: any configuration, the one nearest `q_near`, as
    with ConfJ\\Off). The IK is seeded first from `q_near` (6,) [rad], then from random
    configurations (`seed`) in batches until a solution in `conf` turns up or `MAX_SEEDS`
    are spent; each solution adds its flipped wrist and its whole turns. Of the solutions in
    `conf`, those in it without the border allowance come first, then the nearest to
    `q_near`."""
    solutions = _Solutions(kin, np.asarray(T_base_tcp, float), np.asarray(T_flange_tcp, float))
    rng = np.random.default_rng(seed)

    def pick() -> np.ndarray | None:
        if conf is None:
            ok = solutions.items
        else:
            ok = [q for q in solutions.items if honours(kin, q, conf)]
        if not ok:
            return None
        return min(
            ok,
            key=lambda q: (
                conf is not None and not honours(kin, q, conf, 0.0),
                float(np.linalg.norm(q - q_near)),
            ),
        )

    first = solutions.solve(np.asarray(q_near, dtype=float))
    if first is not None:
        if conf is None:
            return ConfSolution(first, (configuration(kin, first),), True, 0.0)
        solutions.expand(first)
    tried = 1
    while (q := pick()) is None and tried < MAX_SEEDS:
        for _ in range(_BATCH):
            q_found = solutions.solve(kin.random_configuration(rng))
            if q_found is not None:
                solutions.expand(q_found)
        tried += _BATCH
    found = tuple(dict.fromkeys(configuration(kin, s) for s in solutions.items))
    return ConfSolution(q, found, bool(solutions.items), float(solutions.residual_m))
