"""What the TCP check station's light beam reads of a pointed tool (scenarios.offline.tcp_check),
kept as the raw joint readings so that any model of the arm can evaluate them later; and the
cell's commissioning record: each pointed tool read at the beam a few times when the cell was
commissioned, seated by hand and known good, the reference that later checks difference
against (as a BullsEye station's reference TCP)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class BeamCrossing:
    """One sweep of the pointer through the beam at a turn of `spin_deg` [deg] about its
    axis: the encoder joints [rad] (6,) at the first and the last control step the beam was
    broken."""

    spin_deg: float
    q_first: tuple[float, ...]
    q_last: tuple[float, ...]


@dataclass(frozen=True)
class BeamReading:
    """A tool's sweeps through the beam, one per turn (`spins_deg`); `crossings` holds those
    that broke the beam (a turn whose sweep never broke it is missing)."""

    tool: str
    spins_deg: tuple[float, ...]
    crossings: tuple[BeamCrossing, ...]

    @property
    def complete(self) -> bool:
        """Every turn's sweep broke the beam."""
        return len(self.crossings) == len(self.spins_deg)


@dataclass(frozen=True)
class Commissioning:
    """The cell's commissioning record: `references`, each pointed tool's readings at the
    beam (several, the tool taken off and seated again between them), and the cell it was
    made on (`cell`, e.g. "irb2400 seed 3")."""

    cell: str
    references: tuple[BeamReading, ...]

    def readings(self, tool: str) -> tuple[BeamReading, ...]:
        """The reference readings of `tool` (none if the tool was not commissioned)."""
        return tuple(r for r in self.references if r.tool == tool and r.complete)


def as_joints(q: np.ndarray) -> tuple[float, ...]:
    """Joint readings (6,) [rad] as a record keeps them."""
    return tuple(float(v) for v in np.asarray(q, dtype=float))
