"""What only a register-stage trial of a campaign has (scenarios.campaign.register_trial): a
simulated scan matched to the virtual model without the cell; a job's run ignores it."""

from __future__ import annotations

from typing import Literal

from pydantic import (
    Field,
)

from scenarios.offline.settings import (
    Section,
)

#: The built-in models (models.registry) a register trial matches and scans.
BuiltinModel = Literal["skull", "ellipsoid", "bracket", "housing", "lid"]


#: A register campaign's cases (presets of keys: scenarios.campaign.register_job.CASES).
RegisterCase = Literal["default", "symmetric", "small_scan", "wrong_object", "outliers"]


class RegisterTrialArm(Section):
    """The arm's absolute accuracy while it scans, in a register trial's simulated scan (the
    truth): a rigid offset per pass (RMS length `pass_sigma_m` [m], RMS angle
    `pass_rotation_sigma_rad` [rad]) and per-point jitter `jitter_sigma_m` [m]. What the
    matcher is told of it is `localization.registration.pass_sigma_m`."""

    pass_sigma_m: float = Field(3.0e-4, ge=0.0, le=0.01)
    pass_rotation_sigma_rad: float = Field(2.0e-4, ge=0.0, le=0.05)
    jitter_sigma_m: float = Field(5.0e-5, ge=0.0, le=0.01)


class RegisterTrialScan(Section):
    """A register trial's simulated scan (scenarios.campaign.simscan): one orthographic pass
    per tilt (0 looks straight down) [deg], `points` in all, optionally a patch covering
    `coverage` of the surface, a fraction `outliers` of spurious points; `samples` of the
    real surface feed the depth buffer of square cells `cell_m` [m]; samples seen beyond
    `max_incidence_deg` from the surface normal are lost. `sweep_fraction_per_s`: the
    fraction of a pass's sweep the laser covers in a second [1/s], which turns the duration
    [s] of a `faults.laser_dropout_burst` into the fraction of one pass it loses (a skull
    pass of the cell's scan sweeps about 0.32 m at 0.1 m/s: 0.3 of it a second)."""

    tilts_deg: tuple[float, ...] = Field((0.0, 55.0, 70.0), min_length=1)
    points: int = Field(3000, ge=50, le=200_000)
    coverage: float | None = Field(None, gt=0.0, le=1.0)
    outliers: float = Field(0.0, ge=0.0, lt=1.0)
    samples: int = Field(60_000, ge=1000, le=2_000_000)
    cell_m: float = Field(1.5e-3, gt=0.0, le=0.02)
    max_incidence_deg: float = Field(75.0, gt=0.0, le=90.0)
    sweep_fraction_per_s: float = Field(0.3, gt=0.0, le=10.0)


class RegisterTrialSection(Section):
    """What only a register-stage trial has (scenarios.campaign.register_trial): `case`
    labels the campaign's preset of keys; `scanned_model` is what is really on the table
    (None: the job's object, `cell.object.model`; another model makes every accept false);
    `model_seed` shapes the skull (the job's `seed` draws each trial's model error, pose and
    scan); an accepted match with a target beyond `false_accept_m` [m] is a false accept;
    the arm's accuracy (`arm`) and the scan (`scan`) of the simulated scan. Everything else
    the trial reads from the job's own sections (scenarios.campaign.register_job)."""

    case: RegisterCase = "default"
    scanned_model: BuiltinModel | None = None
    model_seed: int = Field(0, ge=0)
    false_accept_m: float = Field(2.0e-3, gt=0.0)
    arm: RegisterTrialArm = RegisterTrialArm()
    scan: RegisterTrialScan = RegisterTrialScan()
