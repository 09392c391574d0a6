"""Faults of the real cell: what goes wrong in a real cell, injected on purpose.

A real cell fails now and then: a tool does not lock, the laser loses a stretch of a pass or
returns wrong ranges off a shiny patch, the table stalls short of its target, someone bumps
the object, a joint reading jumps, a body is left in the arm's way, a tool is heavier than its
tooldata says. Each fault here has an amount (how much), a stage (when: it fires at the first
occasion after the run enters that stage; None: from the start) and an option where the kind
takes one. Random details (which joint, where the patch lies, where the burst starts) are
drawn from the cell's seed.

The faults belong to the real cell (the simulation): the controller and the planning code
never read them; they meet their effects, as a program on a real controller would. The
injector records what it injected and when, for the evaluator.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cell.cell_errors import CellConfigError


@dataclass(frozen=True)
class FaultKind:
    """A kind of fault: what happens, its amount's meaning, unit and default, its default
    stage, and its option's valid values (empty: none)."""

    name: str
    what: str
    amount: str
    unit: str
    default: float
    stage: str | None
    options: tuple[str, ...] = ()


#: The stages of a run, in order (a fault's `stage`).
STAGES = (
    "setup", "calibrate", "probe", "scan", "register", "check", "verify", "execute", "export"
)  # fmt: skip

#: Every fault kind the real cell can have, by name.
FAULT_KINDS: dict[str, FaultKind] = {
    k.name: k
    for k in (
        FaultKind(
            "tool_lock_fail",
            "the changer does not lock (amount 0), or reports locked with the tool seated "
            "`amount` off",
            "seating offset (0: no lock)",
            "m",
            0.0,
            "execute",
            ("gripper", "screwer", "ir", "laser"),
        ),
        FaultKind(
            "laser_dropout_burst",
            "a whole stretch of a pass returns nothing",
            "duration",
            "s",
            1.0,
            "scan",
        ),
        FaultKind(
            "laser_spurious",
            "a reflective patch (20 mm across) on the object returns ranges `amount` too long",
            "range error",
            "m",
            0.01,
            "scan",
        ),
        FaultKind(
            "table_stall",
            "the table stops `amount` short of its target, its readout honest (it shows "
            "where it stopped) or lying (it shows the target)",
            "shortfall",
            "m",
            0.01,
            "scan",
            ("honest", "lying"),
        ),
        FaultKind(
            "object_bump",
            "the object is pushed `amount` across the table (and turned 1 degree per mm) "
            "between the scan and the first touch",
            "displacement",
            "m",
            0.003,
            "verify",
        ),
        FaultKind(
            "encoder_glitch",
            "one reading of a joint jumps by `amount`",
            "jump",
            "rad",
            0.02,
            "scan",
        ),
        FaultKind(
            "obstacle",
            "a box of edge `amount` left in the path of the first operation",
            "edge",
            "m",
            0.06,
            None,
        ),
        FaultKind(
            "payload",
            "the tool weighs `amount` more than its tooldata says",
            "extra mass",
            "kg",
            2.0,
            None,
            ("gripper", "screwer", "ir", "laser"),
        ),
    )
}


@dataclass(frozen=True)
class Fault:
    """One injected fault: its kind's name, amount (SI, see FAULT_KINDS), the stage from
    which it fires (None: from the start), its option (or None), and for an obstacle where
    it stands: (3,) its centre in the table frame [m]."""

    name: str
    amount: float
    stage: str | None = None
    option: str | None = None
    where_table: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        kind = FAULT_KINDS.get(self.name)
        if kind is None:
            raise CellConfigError(
                f"unknown fault {self.name!r}; the faults are: {', '.join(FAULT_KINDS)}"
            )
        if not np.isfinite(self.amount) or self.amount < 0:
            raise CellConfigError(
                f"fault {self.name}: amount must be finite and >= 0 ({kind.amount} "
                f"[{kind.unit}]), got {self.amount!r}"
            )
        if self.stage is not None and self.stage not in STAGES:
            raise CellConfigError(
                f"fault {self.name}: stage {self.stage!r} is not one of: {', '.join(STAGES)}"
            )
        if self.option is not None and self.option not in kind.options:
            valid = ", ".join(kind.options) or "none"
            raise CellConfigError(
                f"fault {self.name}: option {self.option!r} is not one of: {valid}"
            )

    @property
    def kind(self) -> FaultKind:
        return FAULT_KINDS[self.name]


@dataclass(frozen=True)
class Injection:
    """What the injector did: the fault's name, the stage it fired in, the simulated time
    [s] and what happened."""

    name: str
    stage: str
    time_s: float
    detail: str


class FaultInjector:
    """The real cell's faults and their firing. The devices ask `armed(name)` at each
    occasion (a lock, a table move, a laser line, an encoder reading); an armed fault fires
    once (`fire`), at the first occasion after its stage began. The runner tells the stage
    with `enter(stage)`."""

    def __init__(self, faults: tuple[Fault, ...], seed: int) -> None:
        names = [f.name for f in faults]
        if len(set(names)) != len(names):
            raise CellConfigError(f"each fault kind at most once, got {names}")
        self.faults = {f.name: f for f in faults}
        self.rng = np.random.default_rng(np.random.SeedSequence([seed, 11]))
        self.stage = "setup"
        self._reached = 0  # the furthest stage the run reached (its index in STAGES)
        self.fired: dict[str, Injection] = {}
        self.clock: Callable[[], float] = lambda: 0.0
        #: Pushes the object by (4, 4) in the table frame about its centre (the cell's).
        self.push: Callable[[np.ndarray], None] | None = None
        #: A fixed object's move on the table (4, 4, table frame) by a push, by name.
        self.T_table_moved: dict[str, np.ndarray] = {}

    def enter(self, stage: str) -> None:
        """The run enters `stage` now (an object_bump due then happens now)."""
        self.stage = stage
        self._reached = max(self._reached, STAGES.index(stage))
        bump = self.armed("object_bump")
        if bump is not None and self.push is not None:
            direction = self.rng.normal(size=2)
            direction /= np.linalg.norm(direction)
            angle = np.deg2rad(bump.amount * 1e3) * self.rng.choice([-1.0, 1.0])
            c, s = np.cos(angle), np.sin(angle)
            T = np.eye(4)
            T[:2, :2] = [[c, -s], [s, c]]
            T[:2, 3] = bump.amount * direction
            self.push(T)
            self.fire(
                "object_bump",
                f"pushed {bump.amount * 1e3:.1f} mm towards ({direction[0]:+.2f}, "
                f"{direction[1]:+.2f}) and turned {np.rad2deg(angle):+.1f} deg",
            )

    def armed(self, name: str) -> Fault | None:
        """The fault `name` if the run has it, it has not fired yet, and its stage began."""
        fault = self.faults.get(name)
        if fault is None or name in self.fired:
            return None
        if not self._begun(fault):
            return None
        return fault

    def _begun(self, fault: Fault) -> bool:
        """Whether the run reached the fault's stage, or one after it (a job may skip a
        stage: a bump due at the verification happens before the execution anyway)."""
        return fault.stage is None or STAGES.index(fault.stage) <= self._reached

    def fire(self, name: str, detail: str) -> None:
        """Record that fault `name` happened now."""
        self.fired[name] = Injection(name, self.stage, self.clock(), detail)

    def active(self, name: str) -> Fault | None:
        """The fault `name` if the run has it and its stage began (fired or not)."""
        fault = self.faults.get(name)
        if fault is None or not self._begun(fault):
            return None
        return fault
