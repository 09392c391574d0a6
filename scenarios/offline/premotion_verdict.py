"""What the pre-motion check (scenarios.offline.premotion) applies and finds: its limits
(`PremotionLimits`), the problems of a move (`Problem`), the moves it followed
(`CheckedMove`) and its verdict on the program (`PremotionCheck`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from cell.virtual import Contact
from scenarios.scenario_errors import ScenarioError

Kind = Literal["reach", "joint_limit", "singularity", "collision"]
KINDS: tuple[str, ...] = ("reach", "joint_limit", "singularity", "collision")
_VERBS = {
    "collision": "collides",
    "reach": "leaves the arm's reach",
    "joint_limit": "runs into joint limits",
    "singularity": "passes near a singularity",
}


class PremotionError(ScenarioError, ValueError):
    """A pre-motion check asked with bad settings or a bad start."""


@dataclass(frozen=True)
class PremotionLimits:
    """How finely and how strictly the check looks (see scenarios.offline.premotion).

    `step_m` [m] of TCP travel and `step_rad` [rad] of the largest joint's motion between
    samples; `clearance_m` [m] the least distance between the moving side and anything else;
    `touch_clearance_m` [m] that between the tool in hand and the touched object on the lines
    into and out of a touch (0: they may not penetrate); `joint_margin_rad` [rad] inside the
    joint limits; `min_singular_value` of the flange's Jacobian; `watch_m` [m]: distances up
    to this are measured, so that the closest approach of each move is reported.
    """

    step_m: float = 0.005
    step_rad: float = 0.02
    clearance_m: float = 0.002
    touch_clearance_m: float = 0.0
    joint_margin_rad: float = float(np.deg2rad(1.0))
    min_singular_value: float = 0.04
    watch_m: float = 0.1

    def __post_init__(self) -> None:
        for name in ("step_m", "step_rad"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0.0):
                raise PremotionError(f"PremotionLimits.{name} must be > 0, got {value!r}")
        for name in (
            "clearance_m",
            "touch_clearance_m",
            "joint_margin_rad",
            "min_singular_value",
            "watch_m",
        ):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0.0):
                raise PremotionError(f"PremotionLimits.{name} must be >= 0, got {value!r}")
        if max(self.clearance_m, self.touch_clearance_m) > 0.5:
            raise PremotionError(
                "PremotionLimits: clearances beyond 0.5 m are not a clearance, got "
                f"{self.clearance_m!r}, {self.touch_clearance_m!r}"
            )


@dataclass(frozen=True)
class Problem:
    """Why a move may not run: `move` its name ("kocher_left: approach -> touch"), `kind` one
    of KINDS, `detail` what and where ("tool_screwer touches object (2.7 mm deep) from 40 % to
    100 %")."""

    move: str
    kind: Kind
    detail: str

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise PremotionError(f"problem kind {self.kind!r} is not one of {KINDS}")

    def __str__(self) -> str:
        return f"{self.move}: {self.detail}"


@dataclass(frozen=True)
class CheckedMove:
    """A move the check followed: its name, `joint` or `linear`, the poses sampled on it
    (its start excluded: the previous move's end), its closest approach (the smallest
    distance checked against the clearance, within `PremotionLimits.watch_m`; None: nothing
    that near), and on a line into or out of a touch the smallest gap between the tool in
    hand and the touched object [m] (None elsewhere, or nothing that near)."""

    name: str
    kind: Literal["joint", "linear"]
    samples: int
    closest: Contact | None
    touch_gap_m: float | None = None


@dataclass(frozen=True)
class PremotionCheck:
    """The check's verdict: `ok` when no move has a problem; the `problems` in the order of
    the moves; the `moves` followed; the `limits` applied; the wall time [s]."""

    ok: bool
    problems: tuple[Problem, ...]
    moves: tuple[CheckedMove, ...]
    limits: PremotionLimits
    seconds: float = field(default=0.0, compare=False)

    @property
    def samples(self) -> int:
        """The poses checked, over all moves."""
        return sum(m.samples for m in self.moves)

    @property
    def closest(self) -> tuple[str, Contact] | None:
        """The program's closest approach: the move and the contact, or None."""
        near = [(m.name, c) for m in self.moves if (c := m.closest) is not None]
        return min(near, key=lambda item: item[1].distance_m) if near else None

    def kinds(self) -> tuple[str, ...]:
        """The kinds of the problems found, in KINDS' order."""
        return tuple(k for k in KINDS if any(p.kind == k for p in self.problems))

    @property
    def summary(self) -> str:
        """One line: why the program is refused, or what the check found."""
        if self.ok:
            closest = self.closest
            near = (
                f"; closest: {closest[1].body} {closest[1].distance_m * 1e3:.1f} mm from "
                f"{closest[1].other} ({closest[0]})"
                if closest is not None
                else ""
            )
            return (
                f"the corrected program passes the pre-motion check: {len(self.moves)} moves, "
                f"{self.samples} poses, clearance {self.limits.clearance_m * 1e3:g} mm{near}"
            )
        verbs = " and ".join(_VERBS[k] for k in self.kinds())
        shown = "; ".join(str(p) for p in self.problems[:6])
        more = len(self.problems) - 6
        return f"the corrected program {verbs}: {shown}" + (
            f" (and {more} more)" if more > 0 else ""
        )
