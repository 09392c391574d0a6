"""Job configurations: YAML files validated by pydantic (an unknown key or a bad value is
named, with the valid keys near it).

A cell job is one configuration of the one pipeline (scenarios.jobs.pipeline):
- `cell`: the robot, the object and how it is placed, the cell's error sources;
- `model`: where the virtual model comes from (the object's design, or its simulated CT);
- `calibration`: the in-cell kinematic calibration before anything else;
- `localization`: 3D surface matching (`surface`), 2D IR edge probing (`probe`), or both
  side by side (the first one's pose drives the program);
- `operations`: what the program does and where its targets come from;
- `checks`: the goals the run is held to.
- `register_trial` (campaigns only, optional): what only a register-stage trial has, a
  simulated scan matched to the virtual model without the cell
  (scenarios.campaign.register_stage); a job's run ignores it.
The seed paper's experiments (`kind: paper`) are a job of their own.

Shipped configurations live in `scenarios/jobs/configs/<name>.yaml`; `load_config("skull")`
reads a shipped one, `load_config("my.yaml")` a user's file, and `--set KEY=VALUE` overrides
any value by its dotted key. Values are SI ([m], [rad] where the key says so, degrees only in
keys ending in `_deg`).
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any, Literal

import yaml
from pydantic import (
    Field,
    ValidationError,
    field_validator,
    model_validator,
)

from cell.robots import BUILTIN
from cell.sim.faults import FAULT_KINDS, STAGES
from scenarios.errors import ScenarioError
from scenarios.offline.settings import (
    Calibration,
    FixtureTolerance,
    LocalizationSection,
    NominalPlacement,
    OperationsSection,
    PlanningSettings,
    Section,
    VerifySection,
)
from scenarios.results.edge import JsonObject

CONFIG_DIR = Path(__file__).parent / "configs"
CELL_DIR = CONFIG_DIR / "cells"


class ConfigError(ScenarioError, ValueError):
    """A configuration file or value is invalid."""


class Placement(NominalPlacement):
    """Where the object sits on the table: the nominal pose (what the planner believes,
    scenarios.offline.settings.NominalPlacement) and the ranges the real one is drawn from
    around it by the run's seed (the truth: sideways per axis [m], about the vertical and
    tilted [deg]); no stage reads them."""

    range_xy_m: float = Field(0.03, ge=0.0, le=0.2)
    range_yaw_deg: float = Field(20.0, ge=0.0, le=180.0)
    range_tilt_deg: float = Field(5.0, ge=0.0, le=30.0)


class DriveNoise(Section):
    """The arm's drives beyond its kinematics (cell.sim.config.DriveErrors, where the defaults'
    sources are): joint 2 and 3 stiffness [N m/rad] (0: rigid) and its spread, lost motion
    per joint [rad], pose repeatability [rad], thermal zero drift of joints 2 and 3 [rad/s]."""

    stiffness_nm_rad: tuple[float, float] = (1.5e6, 1.0e6)
    stiffness_spread: float = Field(0.1, ge=0.0, le=1.0)
    hysteresis_rad: tuple[float, float, float, float, float, float] = (
        2e-5, 2e-5, 2e-5, 4e-5, 4e-5, 4e-5
    )  # fmt: skip
    repeat_sigma_rad: float = Field(1.0e-5, ge=0.0, le=0.01)
    drift_rad_per_s: tuple[float, float] = (0.0, 0.0)


class ToolNoise(Section):
    """The tools' true TCPs, their seating, the laser's mounting and range scale
    (cell.sim.config.ToolErrors, where the defaults' sources are) [m, rad, relative]."""

    tcp_sigma_m: float = Field(5.0e-5, ge=0.0, le=0.01)
    tcp_sigma_rad: float = Field(2.5e-4, ge=0.0, le=0.1)
    changer_sigma_m: float = Field(5.0e-6, ge=0.0, le=0.01)
    changer_sigma_rad: float = Field(2.0e-5, ge=0.0, le=0.1)
    laser_mount_sigma_m: float = Field(2.0e-4, ge=0.0, le=0.01)
    laser_mount_sigma_rad: float = Field(2.0e-3, ge=0.0, le=0.1)
    laser_scale_sigma: float = Field(3.0e-4, ge=0.0, le=0.1)


class Noise(Section):
    """Error sources of the real cell and of the model."""

    laser_sigma_m: float = Field(1.0e-4, ge=0.0, le=0.01)
    arm_length_sigma_m: float = Field(1.5e-4, ge=0.0, le=0.01)
    arm_offset_sigma_rad: float = Field(1.0e-4, ge=0.0, le=0.01)
    encoder_sigma_rad: float = Field(1.0e-5, ge=0.0, le=0.01)
    table_bias_sigma_m: float = Field(1.0e-4, ge=0.0, le=0.01)
    table_repeat_sigma_m: float = Field(1.0e-5, ge=0.0, le=0.01)
    table_straightness_sigma_m: float = Field(2.0e-5, ge=0.0, le=0.01)
    table_pitch_sigma_rad: float = Field(2.5e-5, ge=0.0, le=0.01)
    table_yaw_sigma_rad: float = Field(2.5e-5, ge=0.0, le=0.01)
    drives: DriveNoise = DriveNoise()
    tools: ToolNoise = ToolNoise()
    model_deformation_rms_m: float = Field(0.24e-3, ge=0.0, le=0.01)
    model_noise_rms_m: float = Field(0.18e-3, ge=0.0, le=0.01)


class ExportSection(Section):
    """What the run hands the controller: `compensation` `filtered` (the robtargets and the
    tooldata written so that a controller without absolute accuracy, computing with its
    nominal arm, reaches the corrected targets with the calibrated arm's joints; needs the
    calibration) or `nominal` (the poses as programmed: such a controller misses them by
    its arm's own error). `execute`: run the exported program at the end of the job on the
    real cell as that controller would (results.json's `exported_program`)."""

    compensation: Literal["filtered", "nominal"] = "filtered"
    execute: bool = True


class Output(Section):
    """What the run writes besides results.json and config.yaml."""

    rrd: bool = True
    plots: bool = True


class ObjectSection(Section):
    """The object of the job: a built-in model (`skull`, `bracket`, `housing`, `lid`,
    `ellipsoid`), a mesh file in `units`, or a CT volume (a DICOM series folder, NIfTI or
    NRRD: its bone at `model.ct.iso_hu`), `fixed` on the table or lying `loose` on it (a
    part the gripper picks), at a pose drawn around the nominal one. Its operation targets
    come from the model (burr holes, screw frames), from `targets_file` (for a CT volume, a
    JSON plan made on it: models.ct.plan), from a `<mesh>.targets.yaml` beside a mesh file,
    or are generated on its upper surface."""

    model: str = "skull"
    units: Literal["m", "mm"] = "mm"
    fixing: Literal["fixed", "loose"] = "fixed"
    placement: Placement = Placement()
    tolerance: FixtureTolerance = FixtureTolerance()
    targets_file: str | None = None


class RobotSection(Section):
    """The cell's arm: `irb2400` (the built-in IRB 2400-class arm), `ur5` (the UR5 of
    example-robot-data) or a 6-axis arm file (`.urdf`, or `.xml` robot-only MJCF) whose
    flange frame is `flange` (required for a file). `mount_xyz` [m] and `mount_yaw_deg` place
    the arm's base in the cell (a file arm or the UR5; the built-in arm stands at the origin);
    `home_deg` (6 values) is its home configuration, the start of every job (a file arm's
    default: all zero); `limits_deg` (lower, upper: 6 values each, within the file's) the
    joint ranges the cell allows it (its safety configuration; default the file's);
    `speed_deg_s` and `effort_nm` (6 values each) its joints' speed and effort limits where
    the file has none (an MJCF file) or they are to be replaced.
    `vendor: abb` gets RAPID programs; other arms get the targets as CSV/JSON."""

    model: str = "irb2400"
    flange: str | None = None
    mount_xyz: tuple[float, float, float] | None = None
    mount_yaw_deg: float = Field(0.0, ge=-180.0, le=180.0)
    home_deg: tuple[float, float, float, float, float, float] | None = None
    limits_deg: (
        tuple[
            tuple[float, float, float, float, float, float],
            tuple[float, float, float, float, float, float],
        ]
        | None
    ) = None
    speed_deg_s: tuple[float, float, float, float, float, float] | None = None
    effort_nm: tuple[float, float, float, float, float, float] | None = None
    vendor: str | None = None

    @model_validator(mode="after")
    def _file_needs_flange(self) -> RobotSection:
        if self.model in BUILTIN:
            if self.flange is not None or (self.model == "irb2400" and self.mount_xyz):
                raise ValueError(
                    f"robot {self.model!r} is built in: it knows its flange (and the irb2400 "
                    "stands at the origin); flange and mount_xyz are for a robot file"
                )
            return self
        if not self.model.lower().endswith((".urdf", ".xml", ".mjcf")):
            raise ValueError(
                f"robot model {self.model!r} is neither built in ({', '.join(BUILTIN)}) "
                "nor a .urdf or .xml (MJCF) file"
            )
        if not self.flange:
            raise ValueError(
                f"robot file {self.model!r} needs `flange`: the name of its flange frame"
            )
        return self


class CellSection(Section):
    """The cell: its robot, where the tool rack stands (`rack_xyz` [m]: the rack frame, the
    slots 0.25 m apart along x from it and 0.8 m above it), the object, and the error
    sources of the real cell and of the model."""

    robot: RobotSection = RobotSection()
    rack_xyz: tuple[float, float, float] = (0.0, -0.85, 0.0)
    object: ObjectSection = ObjectSection()
    noise: Noise = Noise()


class Checks(Section):
    """The goals a run is held to: RMS and largest error of the achieved tool tips against
    the true targets [m] (None: no goal). A match that is not accepted stops the run before
    any motion towards the object, whatever the goals."""

    target_error_rms_m: float | None = Field(0.5e-3, gt=0.0)
    target_error_max_m: float | None = Field(1.0e-3, gt=0.0)


class CTSection(Section):
    """The simulated CT of the real object (`model.source: ct`; models.ct.scanner): voxel size
    (i, j, k) [mm] (a clinical head protocol's 0.5 mm in-plane, 1 mm slices), the
    point-spread function's FWHM [mm], the voxel noise [HU]; `iso_hu` is the segmentation's
    bone threshold. `voxel_mm` also takes one size or "AxBxC" (`--vary
    model.ct.voxel_mm=0.5x0.5x1,1x1x2`). A CT volume given as the object (`cell.object.model`)
    is segmented at `iso_hu` too; a series of it with uneven slice steps or a gantry tilt is
    resampled onto a regular grid at its pixel spacing and smallest step, or at
    `resample_mm` (one size or "AxBxC") if given; a step wider than `max_gap_mm` [mm] is
    refused as missing slices."""

    voxel_mm: tuple[float, float, float] = (0.5, 0.5, 1.0)
    blur_mm: float = Field(0.7, ge=0.0, le=5.0)
    noise_hu: float = Field(20.0, ge=0.0, le=500.0)
    iso_hu: float = 300.0
    resample_mm: tuple[float, float, float] | None = None
    max_gap_mm: float = Field(10.0, gt=0.0)

    @field_validator("voxel_mm", "resample_mm", mode="before")
    @classmethod
    def _voxel(cls, value: Any) -> Any:
        """One size (isotropic) or "AxBxC" (a sweep's value) as well as three sizes."""
        if isinstance(value, int | float) and not isinstance(value, bool):
            return (value, value, value)
        if isinstance(value, str) and "x" in value:
            try:
                return tuple(float(v) for v in value.split("x"))
            except ValueError:
                raise ValueError(f"voxel_mm {value!r}: expected AxBxC in mm") from None
        return value


class ModelSection(Section):
    """Where the virtual model comes from. `phantom`: the object's design (built-in or mesh
    file) is the virtual model, and the real object differs from it by the seeded model
    error of `cell.noise`. `ct`: the design is the real object, and the virtual model is
    segmented and meshed from its simulated CT (`ct`), so the model error is the one a
    CT-derived model has (threshold bias, slice staircase, rounded edges). `tolerance_m`
    [m]: how far the real object's surface may lie from the model, as its drawing, its
    maker or the CT's accuracy states it (two-sided, 95 %; a printed phantom's +-0.5 mm by
    default): the planner's prior, the error budget's floor for the model's term; the
    simulated error itself is `cell.noise`'s."""

    source: Literal["phantom", "ct"] = "phantom"
    ct: CTSection = CTSection()
    tolerance_m: float = Field(5.0e-4, ge=0.0, le=0.01)


class FaultSetting(Section):
    """One fault injected into the real cell (cell.sim.faults.FAULT_KINDS): how much (`amount`,
    SI, None: the kind's default), when (`stage`, None: the kind's default) and its
    `option` (the table readout `honest` or `lying`, the tool of `tool_lock_fail` or
    `payload`). In YAML or `--set`/`--vary`, a bare number is the amount and `true` the
    defaults."""

    amount: float | None = Field(None, ge=0.0)
    stage: Literal[STAGES] | None = None  # type: ignore[valid-type]
    option: str | None = None


def fault_mapping(value: Any, known: Any, unknown: str) -> Any:
    """A faults section as a mapping of name to setting: "a,b" or a list of names (each with
    its defaults) or a mapping; a name not in `known` raises ValueError with `unknown`
    formatted with it."""
    if isinstance(value, str):
        value = [v.strip() for v in value.split(",") if v.strip() and v.strip() != "none"]
    if isinstance(value, list | tuple):
        value = {name: True for name in value}
    if isinstance(value, dict):
        for k in value:
            if k not in known:
                raise ValueError(unknown.format(k))
    return value


def _fault_setting(value: Any) -> Any:
    """A bare number is the amount, "AMOUNT:OPTION" the amount and the option
    (`--vary faults.table_stall=0.002:lying,0.005:lying`), true the defaults, false or null
    no fault."""
    if value is True:
        return {}
    if value is False:
        return None
    if isinstance(value, int | float):
        return {"amount": value}
    if isinstance(value, str) and ":" in value:
        amount, _, option = value.partition(":")
        try:
            return {"amount": float(amount), "option": option.strip()}
        except ValueError:
            return value  # the schema names what is wrong
    return value


class FaultsSection(Section):
    """The faults the real cell will have (none by default). A list or a comma-separated
    string of names gives each its defaults (`--vary faults=table_stall,object_bump`)."""

    tool_lock_fail: FaultSetting | None = None
    laser_dropout_burst: FaultSetting | None = None
    laser_spurious: FaultSetting | None = None
    table_stall: FaultSetting | None = None
    object_bump: FaultSetting | None = None
    encoder_glitch: FaultSetting | None = None
    obstacle: FaultSetting | None = None
    payload: FaultSetting | None = None

    @model_validator(mode="before")
    @classmethod
    def _names(cls, value: Any) -> Any:
        value = fault_mapping(
            value, FAULT_KINDS, "unknown fault {!r}; the faults are: " + ", ".join(FAULT_KINDS)
        )
        if isinstance(value, dict):
            value = {k: _fault_setting(v) for k, v in value.items()}
        return value

    @model_validator(mode="after")
    def _options(self) -> FaultsSection:
        for name, setting in self.active().items():
            options = FAULT_KINDS[name].options
            if setting.option is not None and setting.option not in options:
                raise ValueError(
                    f"{name}.option {setting.option!r} is not one of: "
                    + (", ".join(options) or "none (this fault takes no option)")
                )
        return self

    def active(self) -> dict[str, FaultSetting]:
        """The faults set, by name."""
        return {
            name: setting
            for name in type(self).model_fields
            if (setting := getattr(self, name)) is not None
        }


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
    """What only a register-stage trial has (scenarios.campaign.register_stage): `case`
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


class JobConfig(Section):
    """A cell job: calibrate, scan, localize, program, execute, evaluate, export (see the
    module's docstring for the sections)."""

    kind: Literal["cell"] = "cell"
    name: str = "job"
    seed: int = Field(0, ge=0)
    cell: CellSection = CellSection()
    model: ModelSection = ModelSection()
    calibration: Calibration = Calibration()
    localization: LocalizationSection = LocalizationSection()
    operations: OperationsSection = OperationsSection()
    checks: Checks = Checks()
    export: ExportSection = ExportSection()
    output: Output = Output()
    verify: VerifySection = VerifySection()
    faults: FaultsSection = FaultsSection()
    register_trial: RegisterTrialSection | None = None

    @property
    def object_name(self) -> str:
        """The job's object's name in the cell: "part" for a loose part, else "object"."""
        return "part" if self.cell.object.fixing == "loose" else "object"

    def planning(self) -> PlanningSettings:
        """What the stages are told of this job (scenarios.offline.settings): the planning
        sections, the layout and what the planner believes of the placement; not the real
        cell's noise, faults or placement draws."""
        obj = self.cell.object
        p = obj.placement
        return PlanningSettings(
            seed=self.seed,
            rack_xyz=self.cell.rack_xyz,
            object_name=self.object_name,
            fixing=obj.fixing,
            placement=NominalPlacement(xy_m=p.xy_m, yaw_deg=p.yaw_deg, lift_m=p.lift_m),
            tolerance=obj.tolerance,
            calibration=self.calibration,
            localization=self.localization,
            operations=self.operations,
            verify=self.verify,
            goal_rms_m=self.checks.target_error_rms_m,
            goal_max_m=self.checks.target_error_max_m,
            model_tolerance_m=self.model.tolerance_m,
        )


class PaperConfig(Section):
    """The seed paper's experiments on the ellipsoid."""

    kind: Literal["paper"] = "paper"
    name: str = "paper"
    seed: int = Field(0, ge=0)


Config = JobConfig | PaperConfig
_KINDS: dict[str, type[JobConfig] | type[PaperConfig]] = {"cell": JobConfig, "paper": PaperConfig}


def shipped_names() -> tuple[str, ...]:
    """Names of the configurations shipped with the package."""
    return tuple(sorted(p.stem for p in CONFIG_DIR.glob("*.yaml")))


def describe_validation_error(error: ValidationError) -> str:
    """A pydantic validation error in one line: unknown keys and bad values, each named."""
    parts = []
    for item in error.errors():
        where = ".".join(str(x) for x in item["loc"]) or "(top)"
        if item["type"] == "extra_forbidden":
            parts.append(f"unknown key {where!r}")
        else:
            parts.append(f"{where}: {item['msg']} (got {item.get('input')!r})")
    return "; ".join(parts)


def read_yaml_mapping(path: Path, error: type[Exception] = ConfigError) -> JsonObject:
    """The mapping in a YAML file; a missing file, bad YAML or a non-mapping raise `error`."""
    if not path.is_file():
        raise error(f"{path}: no such configuration file")
    try:
        data = yaml.safe_load(path.read_text()) or {}
    except yaml.YAMLError as exc:
        raise error(f"{path}: not valid YAML: {exc}") from None
    if not isinstance(data, dict):
        raise error(f"{path}: a configuration must be a mapping of keys")
    return data


def parse_config(data: JsonObject, source: str = "config") -> Config:
    """Validate a configuration mapping; its `kind` key ("cell" by default) picks the
    schema."""
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: a configuration must be a mapping, got {type(data).__name__}")
    kind = data.get("kind", "cell")
    if kind not in _KINDS:
        raise ConfigError(f"{source}: 'kind' must be one of {sorted(_KINDS)}, got {kind!r}")
    try:
        return _KINDS[kind].model_validate(data)
    except ValidationError as exc:
        raise ConfigError(f"{source}: {describe_validation_error(exc)}") from None


def set_dotted(data: JsonObject, key: str, value: Any) -> JsonObject:
    """A deep copy of the mapping `data` with the dotted `key` (e.g. "cell.noise.laser_sigma_m")
    set to `value`. Every part of the path but the last must already exist: a typo is refused,
    naming the keys that do."""
    out = copy.deepcopy(data)
    node = out
    parts = key.split(".")
    for depth, part in enumerate(parts):
        if not isinstance(node, dict) or part not in node:
            where = ".".join(parts[:depth]) or "(top)"
            valid = ", ".join(sorted(node)) if isinstance(node, dict) else "none (not a section)"
            raise ConfigError(f"unknown key {key!r}: the keys of {where} are {valid}")
        if depth == len(parts) - 1:
            node[part] = value
        else:
            node = node[part]
    return out


def with_overrides(config: Config, overrides: JsonObject, source: str = "--set") -> Config:
    """The configuration with each dotted key of `overrides` set to its value, validated as
    the YAML is (a bad key or value raises ConfigError naming it)."""
    data = config.model_dump(mode="json")
    for key, value in overrides.items():
        data = set_dotted(data, key, value)
    return parse_config(data, source)


def parse_assignment(text: str) -> tuple[str, Any]:
    """KEY=VALUE of `--set`: the value read as YAML (numbers, true/false, null, lists)."""
    key, sep, raw = text.partition("=")
    if not sep or not key.strip():
        raise ConfigError(f"--set takes KEY=VALUE with a dotted KEY, got {text!r}")
    try:
        value = yaml.safe_load(raw) if raw.strip() else ""
    except yaml.YAMLError as exc:
        raise ConfigError(f"--set {text!r}: the value is not valid YAML ({exc})") from None
    return key.strip(), value


def fault_assignment(text: str) -> tuple[str, Any]:
    """NAME[=AMOUNT[:OPTION]] of `--fault`: the dotted key `faults.NAME` and its value (the
    amount, "AMOUNT:OPTION", or true for the kind's defaults); an unknown name lists the
    faults."""
    name, sep, raw = text.partition("=")
    name = name.strip()
    if name not in FAULT_KINDS:
        raise ConfigError(
            f"--fault {text!r}: unknown fault {name!r}; the faults are: " + ", ".join(FAULT_KINDS)
        )
    if not sep:
        return f"faults.{name}", True
    raw_amount, colon, option = raw.partition(":")
    kind = FAULT_KINDS[name]
    try:
        amount = float(raw_amount)
    except ValueError:
        raise ConfigError(
            f"--fault {text!r}: the amount must be a number ({kind.amount} [{kind.unit}], "
            f"default {kind.default:g})"
        ) from None
    if not colon:
        return f"faults.{name}", amount
    if option not in kind.options:
        valid = ", ".join(kind.options) or "none"
        raise ConfigError(f"--fault {text!r}: option {option!r} is not one of: {valid}")
    return f"faults.{name}", f"{amount!r}:{option}"


def shipped_cells() -> tuple[str, ...]:
    """Names of the cells shipped with the package (`--cell NAME`)."""
    return tuple(sorted(p.stem for p in CELL_DIR.glob("*.yaml")))


def _flatten(data: JsonObject, prefix: str = "") -> JsonObject:
    out: JsonObject = {}
    for key, value in data.items():
        dotted = f"{prefix}{key}"
        if isinstance(value, dict):
            out |= _flatten(value, dotted + ".")
        else:
            out[dotted] = value
    return out


def _shipped_or_file(
    name_or_path: str | Path, kind: str, shipped: tuple[str, ...], folder: Path
) -> Path:
    """The YAML of a shipped `kind` by name (in `folder`) or a user's .yaml file by path."""
    text = str(name_or_path)
    if text in shipped:
        return folder / f"{text}.yaml"
    path = Path(text)
    if path.suffix not in (".yaml", ".yml"):
        raise ConfigError(
            f"unknown {kind} {text!r}; shipped: {', '.join(shipped)}, or give a .yaml file"
        )
    return path


def cell_overrides(name_or_path: str | Path) -> JsonObject:
    """A cell (`--cell`): a shipped one by name or a YAML file by path, holding the keys of
    a job configuration that make the cell (the `cell` section's robot and rack, and what
    follows from the layout, e.g. `calibration.table_positions_m`); returned as dotted
    overrides of the job's configuration, validated with it. A file it names (the robot's,
    say) is found beside it (FILE_KEYS)."""
    path = _shipped_or_file(name_or_path, "cell", shipped_cells(), CELL_DIR)
    return _flatten(_files_beside(read_yaml_mapping(path), path.parent))


FILE_KEYS = (
    "cell.robot.model",
    "cell.object.model",
    "cell.object.targets_file",
    "operations.program",
)
"""The keys of a configuration that may name a file (or a CT series' folder)."""


def _files_beside(data: JsonObject, folder: Path) -> JsonObject:
    """`data` with each relative file of FILE_KEYS that exists beside the configuration file
    (in `folder`) made absolute: a job's files are found beside its YAML, wherever it runs."""
    out = data
    flat = _flatten(data)
    for key in FILE_KEYS:
        value = flat.get(key)
        if isinstance(value, str) and not Path(value).is_absolute():
            beside = folder / value
            if beside.exists():
                out = set_dotted(out, key, str(beside.resolve()))
    return out


def load_config(
    name_or_path: str | Path,
    overrides: JsonObject | None = None,
    cell: str | Path | None = None,
) -> Config:
    """A shipped configuration by name or a YAML file by path, with `overrides` (dotted keys,
    e.g. {"seed": 3, "cell.object.model": "part.stl"}) applied and validated, after the
    `cell` (see `cell_overrides`) if one is given. A configuration without a `name` is named
    after its file."""
    path = _shipped_or_file(name_or_path, "job", shipped_names(), CONFIG_DIR)
    data = _files_beside(read_yaml_mapping(path), path.parent)
    data.setdefault("name", path.stem)
    config = parse_config(data, str(path))
    if cell is not None:
        config = with_overrides(config, cell_overrides(cell), f"cell {cell}")
    return with_overrides(config, overrides, str(path)) if overrides else config


def config_yaml(config: Config) -> str:
    """The resolved configuration as YAML (every key, defaults included)."""
    return yaml.safe_dump(config.model_dump(mode="json"), sort_keys=False)
