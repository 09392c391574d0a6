"""Configuration of a registration-stage trial: a simulated scan of the real object, matched
to the virtual model, without the cell (validated; unknown keys refused). SI units.

The `case` key picks a hard case; it sets the keys listed in `CASES` over the base values
(a sweep's other keys are applied after it).
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from scenarios.campaign.errors import CampaignError
from scenarios.jobs.config import Placement, describe_validation_error, fault_mapping
from scenarios.offline.settings import Registration

_SKULL = Registration()  # the skull job's verdict thresholds: the trials judge alike

Case = Literal["default", "symmetric", "small_scan", "wrong_object", "outliers"]

CASES: dict[str, dict[str, Any]] = {
    "default": {},
    # The paper's ellipsoid: three mirror planes, so 180-degree turns fit as well.
    "symmetric": {"model": "ellipsoid"},
    # One pass from above, a patch of about 10 % of the surface.
    "small_scan": {"scan.tilts_deg": [0.0], "scan.coverage": 0.10},
    # The bracket is scanned and matched against the skull model: any accept is false.
    "wrong_object": {"scanned_model": "bracket"},
    # 40 % of the points spurious, uniform in the scan's padded bounding box.
    "outliers": {"scan.outliers": 0.4},
}


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Laser(_Section):
    """`sigma`: range noise along the ray [m]."""

    sigma: float = Field(1.0e-4, ge=0.0, le=0.01)


class Arm(_Section):
    """Absolute accuracy of the arm while scanning: a rigid offset per pass (RMS length
    `pass_sigma` [m], RMS angle `pass_rotation_sigma` [rad]) and per-point jitter [m]."""

    pass_sigma: float = Field(3.0e-4, ge=0.0, le=0.01)
    pass_rotation_sigma: float = Field(2.0e-4, ge=0.0, le=0.05)
    jitter_sigma: float = Field(5.0e-5, ge=0.0, le=0.01)


class ScanSim(_Section):
    """The simulated scan: one orthographic pass per tilt (0 looks straight down), `points`
    in all, optionally a patch covering `coverage` of the surface, a fraction `outliers` of
    spurious points; `samples` of the real surface feed the depth buffer of `cell` [m]."""

    tilts_deg: tuple[float, ...] = Field((0.0, 55.0, 70.0), min_length=1)
    points: int = Field(3000, ge=50, le=200_000)
    coverage: float | None = Field(None, gt=0.0, le=1.0)
    outliers: float = Field(0.0, ge=0.0, lt=1.0)
    samples: int = Field(60_000, ge=1000, le=2_000_000)
    cell_m: float = Field(1.5e-3, gt=0.0, le=0.02)
    max_incidence_deg: float = Field(75.0, gt=0.0, le=90.0)


class ModelError(_Section):
    """How the real entity differs from the virtual model (RMS over the vertices) [m]."""

    deformation_rms_m: float = Field(0.24e-3, ge=0.0, le=5e-3)
    noise_rms_m: float = Field(0.18e-3, ge=0.0, le=5e-3)


class Matching(_Section):
    """Surface matching and the thresholds of its verdict (by default the skull job's).
    `pass_sigma_m`: the arm's
    accuracy as the matcher is told it (standard deviation of a pass's rigid offset along
    each axis [m], a datasheet figure, with the pass of each point); None: not told."""

    mode: Literal["auto", "local", "global"] = "auto"
    pass_sigma_m: float | None = Field(3.0e-4 / 3**0.5, ge=0.0, le=0.01)
    max_ambiguity: float = Field(_SKULL.max_ambiguity, gt=0.0, le=1.0)
    max_rms_m: float = Field(_SKULL.max_rms_m, gt=0.0)
    max_predicted_tre_m: float = Field(_SKULL.max_predicted_tre_m, gt=0.0)
    min_inlier_fraction: float = Field(_SKULL.min_inlier_fraction, gt=0.0, le=1.0)


def _scan_fault(default: float) -> Any:
    """A scan fault's setting: a number (its amount), true (`default`), false or null
    (none)."""

    def parse(value: Any) -> Any:
        if value is True:
            return default
        if value is False:
            return None
        return value

    return parse


class ScanFaults(_Section):
    """The scan faults of the cell's laser, on the simulated scan: `laser_dropout_burst`, the
    fraction of one pass's sweep that returns nothing (true: 0.3); `laser_spurious`, the
    range error [m] of a reflective patch's returns (true: 0.01). None: no fault."""

    laser_dropout_burst: float | None = Field(None, gt=0.0, lt=1.0)
    laser_spurious: float | None = Field(None, gt=0.0, le=0.1)

    @model_validator(mode="before")
    @classmethod
    def _names(cls, value: Any) -> Any:
        value = fault_mapping(
            value,
            SCAN_FAULT_DEFAULTS,
            "unknown scan fault {!r}; the register stage has the scan faults: "
            + ", ".join(SCAN_FAULT_DEFAULTS),
        )
        if isinstance(value, dict):
            value = {k: _scan_fault(SCAN_FAULT_DEFAULTS[k])(v) for k, v in value.items()}
        return value

    def active(self) -> dict[str, float]:
        return {k: v for k, v in self.model_dump().items() if v is not None}


#: The scan faults' amounts when set to true.
SCAN_FAULT_DEFAULTS = {"laser_dropout_burst": 0.3, "laser_spurious": 0.01}


class RegisterConfig(_Section):
    """One registration trial. `model` is the virtual model matched against; `scanned_model`
    (default: the same) is what is really on the table; `model_seed` shapes the skull."""

    stage: Literal["register"] = "register"
    case: Case = "default"
    model: Literal["skull", "ellipsoid", "bracket", "housing", "lid"] = "skull"
    scanned_model: Literal["skull", "ellipsoid", "bracket", "housing", "lid"] | None = None
    model_seed: int = Field(0, ge=0)
    false_accept_m: float = Field(2.0e-3, gt=0.0)
    laser: Laser = Laser()
    arm: Arm = Arm()
    scan: ScanSim = ScanSim()
    model_error: ModelError = ModelError()
    placement: Placement = Placement()
    registration: Matching = Matching()
    faults: ScanFaults = ScanFaults()


def default_register_config() -> dict[str, Any]:
    """The default registration-trial configuration as a plain dict (every key)."""
    return RegisterConfig().model_dump(mode="json")


def parse_register_config(data: dict[str, Any], source: str = "register config") -> RegisterConfig:
    """Validate a registration-trial configuration; bad keys and values are named."""
    try:
        return RegisterConfig.model_validate(data)
    except ValidationError as exc:
        raise CampaignError(f"{source}: {describe_validation_error(exc)}") from None
