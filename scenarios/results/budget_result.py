"""The error budget of a job's targets as results.json keeps it (scenarios.offline.error_budget
makes it from what the job measured): per target, each term's standard error [m] and their
sum in quadrature; the bound that covers the true error at 95 % of targets (the sum times
the coverage factor calibrated on campaigns); and whether that puts the job's goals within
reach."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: The budget's terms, in the order results.json, the table and targets.png give them.
TERMS = ("tre_m", "arm_m", "tool_m", "model_m")


@dataclass(frozen=True)
class TargetBudget:
    """One target's budget [m]: the registration's predicted TRE there, the calibrated arm's
    error, the tool's as its check at the beam read it, and the model's tolerance, each as a
    standard error (RMS length); `bound_m`: what the true error stays within at 95 % of
    targets."""

    name: str
    tre_m: float
    arm_m: float
    tool_m: float
    model_m: float
    bound_m: float

    @property
    def sigma_m(self) -> float:
        """The terms in quadrature [m]."""
        return float(np.sqrt(self.tre_m**2 + self.arm_m**2 + self.tool_m**2 + self.model_m**2))

    @property
    def largest(self) -> str:
        """The term that weighs most ("tre", "arm", "tool" or "model")."""
        values = {t: getattr(self, t) for t in TERMS}
        return max(values, key=values.__getitem__).removesuffix("_m")


@dataclass(frozen=True)
class ErrorBudget:
    """The job's targets' budgets, the coverage factors they were scaled by (`k_target`:
    each target's bound is its sigma times it; `k_rms`: the run's RMS bound is the targets'
    RMS sigma times it), and the goals [m] (None: none) they are held to. A goal is within
    reach when its bound is within it."""

    targets: tuple[TargetBudget, ...]
    k_target: float
    k_rms: float
    goal_rms_m: float | None
    goal_max_m: float | None

    @property
    def rms_bound_m(self) -> float:
        """The bound [m] the run's target RMS stays within at 95 % of runs."""
        sigmas = np.array([t.sigma_m for t in self.targets])
        return float(self.k_rms * np.sqrt(np.mean(sigmas**2))) if len(sigmas) else 0.0

    @property
    def max_bound_m(self) -> float:
        """The largest target's bound [m]."""
        return max((t.bound_m for t in self.targets), default=0.0)

    @property
    def risks(self) -> tuple[str, ...]:
        """Each goal the budget does not put within reach, said in a line with the term that
        weighs most."""
        out = []
        if self.goal_rms_m is not None and self.rms_bound_m > self.goal_rms_m:
            terms = _mean_terms(self.targets)
            worst = max(terms, key=terms.__getitem__)
            out.append(
                f"the RMS goal {self.goal_rms_m * 1e3:.3f} mm is within reach only to "
                f"{self.rms_bound_m * 1e3:.3f} mm (largest term: {worst}, "
                f"{terms[worst] * 1e3:.3f} mm)"
            )
        if self.goal_max_m is not None and self.max_bound_m > self.goal_max_m:
            worst_target = max(self.targets, key=lambda t: t.bound_m)
            out.append(
                f"the largest-error goal {self.goal_max_m * 1e3:.3f} mm is within reach only "
                f"to {worst_target.bound_m * 1e3:.3f} mm at {worst_target.name} (largest "
                f"term: {worst_target.largest}, "
                f"{getattr(worst_target, worst_target.largest + '_m') * 1e3:.3f} mm)"
            )
        return tuple(out)

    @property
    def within_reach(self) -> bool:
        return not self.risks

    def summary(self) -> str:
        """One line: the bounds against the goals, and what is at risk."""
        text = (
            f"error budget: RMS within {self.rms_bound_m * 1e3:.3f} mm, largest within "
            f"{self.max_bound_m * 1e3:.3f} mm (95 %)"
        )
        return text + (
            "; goals within reach" if self.within_reach else "; " + "; ".join(self.risks)
        )


def _mean_terms(targets: tuple[TargetBudget, ...]) -> dict[str, float]:
    """Each term's RMS over the targets [m], by its short name."""
    return {
        t.removesuffix("_m"): float(np.sqrt(np.mean([getattr(b, t) ** 2 for b in targets])))
        for t in TERMS
    }
