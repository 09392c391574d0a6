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
    reference spheres). Set the level your arm's warm-up measured.

    The links grow with their temperature too (`cell.noise.arm_thermal_strain`, each job's
    from `thermal_strain`): `expansion_per_k` is cast aluminium's 23e-6 per K (steel's is
    about 12e-6); the links' rise once fully warm, `link_warmup_k` (3 K), and the workshop's
    change over the shift, `ambient_k_per_h` (+0.5 K an hour: 2 K over a 4 h shift), are
    assumed, not measured: together about 0.1 mm at the built-in arm's TCP by the shift's
    end. Set what your cell's thermometers read; zeros keep the links as they are."""

    jobs: int = Field(12, ge=1)
    hours: float = Field(4.0, gt=0.0)
    policy: Policy = "check"
    warmup_rad: Joints = (0.0, 5.0e-4, 5.0e-4, 0.0, 0.0, 0.0)
    duty: float = Field(0.5, ge=0.0, le=1.0)
    expansion_per_k: float = Field(2.3e-5, ge=0.0, le=1.0e-4)
    link_warmup_k: float = Field(3.0, ge=0.0, le=50.0)
    ambient_k_per_h: float = Field(0.5, ge=-10.0, le=10.0)

    def thermal_strain(self, warmth: float, hours: float) -> float:
        """The links' growth (dL/L) of an arm `warmth` warm (0 cold, 1 fully warm), `hours`
        into the shift: `expansion_per_k` times the links' temperature rise,
        `link_warmup_k` times the warmth plus `ambient_k_per_h` times the hours."""
        rise_k = self.link_warmup_k * warmth + self.ambient_k_per_h * hours
        return self.expansion_per_k * rise_k
