"""A register trial's configuration: a cell job's (scenarios.configuration.job_config.JobConfig).

A register trial (scenarios.campaign.register_trial) reads what a job already has from the
job's own sections, and what only a simulated-scan trial has from `register_trial`:
- the object: `cell.object.model` (a built-in model) and the draw of its real placement,
  `cell.object.placement`;
- the laser's range noise `cell.noise.laser_sigma_m`; the model error
  `cell.noise.model_deformation_rms_m` and `cell.noise.model_noise_rms_m`;
- the match's mode, the pass accuracy it is told and its verdict's thresholds,
  `localization.registration` (not its `voxel_m` and `max_points`, which thin a cell's scan:
  the trial matches every point of its simulated scan, `register_trial.scan.points`);
- the seed, `seed` (each trial's own: the campaign's `--seed` plus the trial's index);
- the scan faults `faults.laser_dropout_burst` (its amount a duration [s]: the fraction
  `amount * register_trial.scan.sweep_fraction_per_s` of one pass is lost) and
  `faults.laser_spurious` (its amount the range error [m] of a shiny patch); with no
  amount, the cell's defaults (1 s, that is 0.3 of a pass; 10 mm).

Refused, naming what was given and what is valid: a model that is not built in, a CT model
(`model.source: ct`), a targets file, the mode "refine" (it needs a prior pose), the cell's
other faults, and a sweep of a key the trial does not read (READ_KEYS).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import get_args

from pydantic import ValidationError

from cell.sim.faults import FAULT_KINDS
from scenarios.campaign.campaign_errors import CampaignError
from scenarios.configuration.config_files import describe_validation_error
from scenarios.configuration.fault_sections import FaultSetting
from scenarios.configuration.job_config import JobConfig
from scenarios.configuration.register_trial_sections import BuiltinModel, RegisterTrialSection
from scenarios.results.edge import JsonObject

#: The built-in models a register trial can match and scan.
MODELS: tuple[str, ...] = get_args(BuiltinModel)

#: The dotted key of a register campaign's case: sweeping it sets the case's keys (CASES)
#: before the other swept keys.
CASE_KEY = "register_trial.case"

CASES: dict[str, JsonObject] = {
    "default": {},
    # The paper's ellipsoid: three mirror planes, so 180-degree turns fit as well.
    "symmetric": {"cell.object.model": "ellipsoid"},
    # One pass from above, a patch of about 10 % of the surface.
    "small_scan": {"register_trial.scan.tilts_deg": [0.0], "register_trial.scan.coverage": 0.10},
    # The bracket is scanned and matched against the skull model: any accept is false.
    "wrong_object": {"register_trial.scanned_model": "bracket"},
    # 40 % of the points spurious, uniform in the scan's padded bounding box.
    "outliers": {"register_trial.scan.outliers": 0.4},
}
"""Each case's keys, set over the base configuration when `register_trial.case` is swept."""

#: The job's keys a register trial reads (a key, or a section and every key under it).
READ_KEYS: tuple[str, ...] = (
    "cell.object.model",
    "cell.object.placement",
    "cell.noise.laser_sigma_m",
    "cell.noise.model_deformation_rms_m",
    "cell.noise.model_noise_rms_m",
    "localization.registration.mode",
    "localization.registration.pass_sigma_m",
    "localization.registration.max_ambiguity",
    "localization.registration.max_rms_m",
    "localization.registration.max_predicted_tre_m",
    "localization.registration.min_inlier_fraction",
    "faults",
    "register_trial",
)

#: The faults of the cell's laser that a register trial's simulated scan has.
SCAN_FAULTS: tuple[str, ...] = ("laser_dropout_burst", "laser_spurious")

#: The largest range error of a shiny patch the simulated scan takes [m].
MAX_SPURIOUS_M = 0.1


@dataclass(frozen=True)
class ScanFaultAmounts:
    """The scan faults of a register trial in the simulated scan's terms: the fraction of one
    pass's sweep a dropout burst loses, and the range error [m] of a shiny patch's returns;
    None: no such fault."""

    dropout_burst: float | None = None
    spurious_m: float | None = None

    @property
    def names(self) -> tuple[str, ...]:
        """The faults set, by the job's names, in the order of SCAN_FAULTS."""
        amounts = (self.dropout_burst, self.spurious_m)
        return tuple(n for n, a in zip(SCAN_FAULTS, amounts, strict=True) if a is not None)


@dataclass(frozen=True)
class RegisterTrialSetup:
    """A register trial's configuration, checked: the job, its `register_trial` section
    (the defaults where the job has none) and its scan faults' amounts."""

    job: JobConfig
    trial: RegisterTrialSection
    faults: ScanFaultAmounts


def register_base(model: str) -> JsonObject:
    """The base configuration of a register campaign on the built-in `model`: the default job
    on that object, with the default `register_trial` section, as a plain dict (every key)."""
    if model not in MODELS:
        raise CampaignError(f"unknown model {model!r}; the built-in models are {', '.join(MODELS)}")
    data = {"name": model, "cell": {"object": {"model": model}}, "register_trial": {}}
    return parse_register_job(data, f"model {model}").job.model_dump(mode="json")


def parse_register_job(data: JsonObject, source: str = "register trial") -> RegisterTrialSetup:
    """Validate a job configuration (a mapping) as a register trial's; a bad key or value, or
    a setting the trial cannot honour, raises CampaignError naming it and what is valid."""
    try:
        job = JobConfig.model_validate(data)
    except ValidationError as exc:
        raise CampaignError(f"{source}: {describe_validation_error(exc)}") from None
    trial = job.register_trial or RegisterTrialSection()
    job = job.model_copy(update={"register_trial": trial})
    _check_job(job, source)
    return RegisterTrialSetup(job, trial, _scan_fault_amounts(job, trial, source))


def check_read_keys(keys: Iterable[str]) -> None:
    """Refuse a swept key that a register trial does not read (see READ_KEYS)."""
    for key in keys:
        if not any(key == k or key.startswith(k + ".") for k in READ_KEYS):
            raise CampaignError(
                f"--vary {key!r}: the register stage does not read this key of the job; it "
                f"reads {', '.join(READ_KEYS)} (a section: any key under it)"
            )


def _check_job(job: JobConfig, source: str) -> None:
    """Refuse what a register trial cannot honour: a model that is not built in, a CT model,
    a targets file, the mode "refine"."""
    obj = job.cell.object
    if obj.model not in MODELS:
        raise CampaignError(
            f"{source}: cell.object.model {obj.model!r}: the register stage matches a "
            f"built-in model: {', '.join(MODELS)}"
        )
    if job.model.source != "phantom":
        raise CampaignError(
            f"{source}: model.source {job.model.source!r}: the register stage matches the "
            "object's design (phantom); a CT model is for --stage full"
        )
    if obj.targets_file is not None:
        raise CampaignError(
            f"{source}: cell.object.targets_file {obj.targets_file!r}: the register stage "
            "evaluates the built-in model's own targets (none: leave it unset)"
        )
    mode = job.localization.registration.mode
    if mode == "refine":
        raise CampaignError(
            f"{source}: localization.registration.mode {mode!r} needs a prior pose; the "
            "register stage matches with auto, local or global"
        )


def _amount(name: str, setting: FaultSetting, source: str) -> float:
    """The fault's amount in the job's terms (its kind's default if not given); a stage other
    than the scan is refused."""
    if setting.stage not in (None, "scan"):
        raise CampaignError(
            f"{source}: faults.{name}.stage {setting.stage!r}: the register stage's scan "
            "faults happen during its scan (stage scan, or none)"
        )
    return FAULT_KINDS[name].default if setting.amount is None else setting.amount


def _scan_fault_amounts(
    job: JobConfig, trial: RegisterTrialSection, source: str
) -> ScanFaultAmounts:
    """The job's scan faults in the simulated scan's terms; another fault, or an amount out
    of the simulated scan's range, is refused."""
    active = job.faults.active()
    for name in active:
        if name not in SCAN_FAULTS:
            raise CampaignError(
                f"{source}: unknown scan fault {name!r}; the register stage has the scan "
                f"faults: {', '.join(SCAN_FAULTS)}"
            )
    burst = spurious = None
    if "laser_dropout_burst" in active:
        seconds = _amount("laser_dropout_burst", active["laser_dropout_burst"], source)
        rate = trial.scan.sweep_fraction_per_s
        burst = seconds * rate
        if not 0.0 < burst < 1.0:
            raise CampaignError(
                f"{source}: faults.laser_dropout_burst: a burst of {seconds:g} s loses "
                f"{burst:g} of a pass (register_trial.scan.sweep_fraction_per_s {rate:g}); the "
                f"register stage takes a burst longer than 0 s and shorter than a pass "
                f"({1.0 / rate:g} s)"
            )
    if "laser_spurious" in active:
        spurious = _amount("laser_spurious", active["laser_spurious"], source)
        if not 0.0 < spurious <= MAX_SPURIOUS_M:
            raise CampaignError(
                f"{source}: faults.laser_spurious: the range error must be in "
                f"(0, {MAX_SPURIOUS_M:g}] m, got {spurious:g}"
            )
    return ScanFaultAmounts(burst, spurious)
