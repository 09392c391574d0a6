"""The checks before and at the first touch as results.json keeps them: the verification
(scenarios.offline.verification measures it: per target, the object's move measured since the
scan, the measurement's own bound, what the job's goal allows and the decision; the strips
scanned again and their cell time) and the tools' checks at the beam
(scenarios.offline.tcp_check)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

Decision = Literal["agrees", "moved", "inconsistent", "unresolved"]


@dataclass(frozen=True)
class TargetCheck:
    """One target: how far the object moved it between the scan and the verification
    (`moved_m` [m], measured; `uncertainty_m` [m]: the bound the measurement's own noise
    stays under), the move the goal allows (`allowance_m` [m]); and how far the second
    strip's own match places it from the registration (`disagreement_m` [m]) against what
    the two matches' predicted TREs allow (`disagreement_allowed_m` [m])."""

    name: str
    moved_m: float
    uncertainty_m: float
    allowance_m: float
    disagreement_m: float
    disagreement_allowed_m: float
    goal_m: float = float("inf")

    @property
    def resolved(self) -> bool:
        """Whether the measurement tells a move of the allowance from none (its bound is
        within the allowance) and surely sees a move beyond the goal `goal_m` [m] (the
        allowance plus the bound is within the goal)."""
        u, a = self.uncertainty_m, self.allowance_m
        return a > 0 and u <= a and a + u <= self.goal_m

    @property
    def resolves_m(self) -> float:
        """The least move [m] this check surely catches: the allowance plus the bound."""
        return max(self.allowance_m, 0.0) + self.uncertainty_m

    @property
    def decision(self) -> Decision:
        """ "moved": beyond the allowance and beyond what the measurement's own noise
        explains; "inconsistent": the second scan's own match too far from the
        registration; else "agrees" if resolved, "unresolved" if not (a move it cannot tell
        from none is not called a move)."""
        if self.moved_m > max(self.allowance_m, self.uncertainty_m):
            return "moved"
        if self.disagreement_m > self.disagreement_allowed_m:
            return "inconsistent"
        return "agrees" if self.resolved else "unresolved"


@dataclass(frozen=True)
class Verification:
    """The strips scanned again (their passes' names), their points on the object, the
    cell time they took [s], each target's check; the registration agrees if no target
    moved beyond its allowance or disagrees with the second scan. `verified_to_m`: the least
    target move [m] the verification surely catches."""

    strips: tuple[str, ...]
    points: int
    scan_time_s: float
    checks: tuple[TargetCheck, ...]

    @property
    def agrees(self) -> bool:
        return self.points > 0 and all(c.decision in ("agrees", "unresolved") for c in self.checks)

    @property
    def resolved(self) -> bool:
        """Whether every target's check tells a move of its allowance from none."""
        return bool(self.checks) and all(c.resolved for c in self.checks)

    @property
    def verified_to_m(self) -> float:
        return max((c.resolves_m for c in self.checks), default=float("inf"))

    def summary(self) -> str:
        strips = " + ".join(self.strips)
        if not self.checks:
            return f"{strips} again: {self.points} points on the object, too few to match"
        worst = max(self.checks, key=_worst_key)
        if worst.decision == "inconsistent":
            return (
                f"{strips} again ({self.points} points): its own match places {worst.name} "
                f"{worst.disagreement_m * 1e3:.2f} mm from the registration's (allowed "
                f"{worst.disagreement_allowed_m * 1e3:.2f})"
            )
        text = (
            f"{strips} again ({self.points} points): the targets moved up to "
            f"{worst.moved_m * 1e3:.3f} mm ({worst.name}; allowed {worst.allowance_m * 1e3:.3f},"
            f" measured to {worst.uncertainty_m * 1e3:.3f})"
        )
        if not self.resolved:
            text += f"; verified to {self.verified_to_m * 1e3:.2f} mm only"
        return text


def _worst_key(c: TargetCheck) -> tuple[int, float]:
    order = {"inconsistent": 2, "moved": 3, "unresolved": 1, "agrees": 0}
    return order[c.decision], c.moved_m / max(c.allowance_m, 1e-9)


ToolDecision = Literal["seated", "off", "unresolved"]

#: A tool is called off only beyond this many standard deviations of its check's reading: a
#: seated tool's reading (two-dimensional, Gaussian) goes beyond 4 sigma once in 3000 checks.
K_SIGMA = 4.0
#: A seated tool read beyond this many of its standard deviations has shifted on its seat
#: since commissioning (a good seat reads that far once in 90 checks): the job corrects the
#: tool's TCP by the reading, as a BullsEye station updates the tooldata [-].
K_CORRECT = 3.0


@dataclass(frozen=True)
class TcpCheck:
    """A tool checked at the beam after it was locked (scenarios.offline.tcp_check): its
    pointer's sideways offset (x, y) from where it should sit, in the tool frame [m] (inf
    where a sweep did not see it); `sigma_m` [m]: the reading's own standard deviation per
    axis on this cell (what a seated tool reads); `tolerance_m` [m]: the offset the job's
    goal allows; `referenced`: differenced against the cell's commissioning reference (else
    against the tooldata, the arm's own error at the beam in the reading); which attempt it
    was (0: as first seated, 1: seated again).

    A tool is off only beyond both the tolerance and K_SIGMA sigma; where K_SIGMA sigma is
    beyond the tolerance, a reading within it is "unresolved": the tool is checked to that
    much only. A seated tool whose referenced reading lies beyond K_CORRECT sigma is
    `corrected`: the job moves its TCP by the reading."""

    tool: str
    offset_m: tuple[float, float]
    tolerance_m: float
    attempt: int = 0
    sigma_m: float = 0.0
    referenced: bool = False

    @property
    def off_m(self) -> float:
        return float(np.hypot(*self.offset_m))

    @property
    def resolves_m(self) -> float:
        """The offset [m] beyond which the check calls the tool off: the tolerance, or
        K_SIGMA sigma if that is more."""
        return max(self.tolerance_m, K_SIGMA * self.sigma_m)

    @property
    def resolved(self) -> bool:
        """Whether the check tells a tool off by its tolerance from a seated one."""
        return K_SIGMA * self.sigma_m <= self.tolerance_m

    @property
    def decision(self) -> ToolDecision:
        if not self.off_m <= self.resolves_m:  # inf: a sweep missed the beam
            return "off"
        return "seated" if self.resolved else "unresolved"

    @property
    def ok(self) -> bool:
        """The tool may be used: not called off."""
        return self.decision != "off"

    @property
    def corrected(self) -> bool:
        """Whether the job corrects the tool's TCP by this reading: the tool is seated and
        its reading, against the commissioning reference, lies beyond K_CORRECT standard
        deviations: a shift of the seat, not the reading's scatter. A reading against the
        tooldata holds the arm's own error and corrects nothing."""
        return (
            self.referenced and self.decision == "seated" and self.off_m > K_CORRECT * self.sigma_m
        )

    @property
    def T_tcp_measured(self) -> np.ndarray:
        """(4, 4) the TCP as this check measured it, in the tooldata's TCP frame: shifted
        sideways by the reading where the check corrects it (`corrected`), else the
        identity."""
        T = np.eye(4)
        if self.corrected:
            T[:2, 3] = self.offset_m
        return T

    @property
    def T_flange_tool(self) -> np.ndarray:
        """(4, 4) where the tool sits on the flange, as measured: shifted sideways."""
        T = np.eye(4)
        T[:2, 3] = self.offset_m
        return T

    def summary(self) -> str:
        if not np.isfinite(self.off_m):
            return f"the {self.tool}'s pointer missed the beam: it sits far off its tooldata"
        against = "its commissioning reference" if self.referenced else "its tooldata"
        text = (
            f"the {self.tool}'s pointer is {self.off_m * 1e3:.2f} mm off {against} "
            f"(x {self.offset_m[0] * 1e3:+.2f}, y {self.offset_m[1] * 1e3:+.2f} mm; "
            f"tolerance {self.tolerance_m * 1e3:.2f} mm, measured to "
            f"{self.sigma_m * 1e3:.3f} mm)"
        )
        if self.decision == "unresolved":
            text += f"; checked to {self.resolves_m * 1e3:.2f} mm only"
        return text

    @property
    def verdict(self) -> str:
        """The decision as a user reads it: "seated, TCP corrected" where it was."""
        return "seated, TCP corrected" if self.corrected else self.decision
