"""A shift of jobs on one real cell (`twincell shift`): how many jobs over how long, what each
does with the calibration, and how the arm warms and cools."""

from __future__ import annotations

from pydantic import Field

from scenarios.offline.settings import Section
from scenarios.results.shift_result import Policy

Joints = tuple[float, float, float, float, float, float]


class ShiftSection(Section):
    """A shift (scenarios.jobs.shift): `jobs` started evenly over `hours` of the cell's clock,
    each doing with the calibration what `policy` says (scenarios.results.shift_result
    .POLICIES; `twincell shift --jobs --hours --policy` set them, and a campaign's `--stage
    shift` sweeps them like any key).

    The real cell's arm over the shift (truth, never read by the stages): each joint's zero
    shift once the arm is fully warm [rad], given to the shift's jobs as
    `cell.noise.drives.warmup_rad` (all zero: a shift without warm-up), and `duty`, the
    share of the time between jobs the arm works on other parts (it warms towards `duty` of
    fully warm, with `cell.noise.drives.warmup_tau_s`; 0: it stands and cools).

    The default level is assumed, not measured on an arm: 0.5 mrad at joints 2 and 3 moves
    the skull's targets by about 1 mm on the built-in arm once fully warm (0.6 mm at the
    calibration's spheres), the order of the warm-up drift reported for mid-size arms, whose
    repeatability cold and warm can differ tenfold (Appl. Sci. 2021, 11(22), 10813, an ABB
    IRB 1200; Int. J. Adv. Manuf. Technol. 75 (2014) 933-946, warm-up and cool-down seen on
    reference spheres). Set the level your arm's warm-up measured."""

    jobs: int = Field(12, ge=1)
    hours: float = Field(4.0, gt=0.0)
    policy: Policy = "check"
    warmup_rad: Joints = (0.0, 5.0e-4, 5.0e-4, 0.0, 0.0, 0.0)
    duty: float = Field(0.5, ge=0.0, le=1.0)
