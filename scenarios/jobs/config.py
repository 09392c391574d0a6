"""Run configurations: YAML files validated by pydantic (an unknown key or a bad value is named).

Shipped configurations live in `scenarios/configs/<name>.yaml`; `load_config("skull")` reads a
shipped one, `load_config("my.yaml")` a user's file. Values are SI ([m], [rad] where the key
says so, degrees only in keys ending in `_deg`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from scenarios.errors import ScenarioError

CONFIG_DIR = Path(__file__).parent / "configs"


class ConfigError(ScenarioError, ValueError):
    """A configuration file or value is invalid."""


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Placement(_Section):
    """Where the object sits on the table: a nominal pose (what the planner believes) and the
    random deviation of the real one (drawn from the run's seed)."""

    xy_m: tuple[float, float] = (0.0, 0.0)
    yaw_deg: float = 180.0
    lift_m: float = Field(0.004, ge=0.0, le=0.1)
    range_xy_m: float = Field(0.03, ge=0.0, le=0.2)
    range_yaw_deg: float = Field(20.0, ge=0.0, le=180.0)
    range_tilt_deg: float = Field(5.0, ge=0.0, le=30.0)


class Noise(_Section):
    """Error sources of the real cell and of the model."""

    laser_sigma_m: float = Field(1.0e-4, ge=0.0, le=0.01)
    arm_length_sigma_m: float = Field(1.5e-4, ge=0.0, le=0.01)
    arm_offset_sigma_rad: float = Field(1.0e-4, ge=0.0, le=0.01)
    encoder_sigma_rad: float = Field(1.0e-5, ge=0.0, le=0.01)
    table_bias_sigma_m: float = Field(1.0e-4, ge=0.0, le=0.01)
    table_repeat_sigma_m: float = Field(1.0e-5, ge=0.0, le=0.01)
    model_deformation_rms_m: float = Field(0.24e-3, ge=0.0, le=0.01)
    model_noise_rms_m: float = Field(0.18e-3, ge=0.0, le=0.01)


class ScanPass(_Section):
    """One straight laser pass. With `heading_deg` 0: the laser looks down, tilted by
    `tilt_deg` about the table's y axis (positive: towards +x, away from the robot), aimed
    `offset_m` along x from the object's centre, and the sweep runs along y over the object's
    width plus `margin_m`. `heading_deg` turns all of that about the table's vertical (90:
    the laser looks towards +y and sweeps along x)."""

    tilt_deg: float = Field(0.0, ge=-75.0, le=75.0)
    offset_m: float = Field(0.0, ge=-0.5, le=0.5)
    heading_deg: float = Field(0.0, ge=-180.0, le=180.0)


class Scan(_Section):
    """The scan plan's parameters."""

    standoff_m: float = Field(0.28, gt=0.05, le=0.6)
    speed_m_s: float = Field(0.1, gt=0.0, le=0.5)
    period_s: float = Field(0.01, ge=0.002, le=0.5)
    margin_m: float = Field(0.04, ge=0.0, le=0.3)
    min_points: int = Field(10_000, ge=100)
    passes: tuple[ScanPass, ...] = Field(
        (
            ScanPass(tilt_deg=0.0, offset_m=-0.05),
            ScanPass(tilt_deg=0.0, offset_m=0.05),
            ScanPass(tilt_deg=55.0, offset_m=-0.06),
            ScanPass(tilt_deg=70.0, offset_m=-0.03),
            ScanPass(tilt_deg=45.0, heading_deg=90.0),
            ScanPass(tilt_deg=45.0, heading_deg=-90.0),
        ),
        min_length=1,
    )


class Registration(_Section):
    """Surface matching of the scan to the virtual model: the object points are thinned to
    one per `voxel_m` cube (so that regions scanned twice do not outweigh the others), then
    at most `max_points` of them are drawn (seeded). `mode` "auto" searches every pose
    (no prior, any coverage); "local" and "global" search for a partial or a whole-surface
    scan; "refine" starts from a prior pose. `pass_sigma_m`: the arm's absolute
    accuracy as the matcher is told it (a scan pass's rigid offset per axis [m], about
    0.3 mm in all, a datasheet figure) for the predicted TRE; None: not told."""

    voxel_m: float = Field(0.003, ge=0.0, le=0.05)
    mode: Literal["auto", "local", "global", "refine"] = "auto"
    pass_sigma_m: float | None = Field(3.0e-4 / 3**0.5, ge=0.0, le=0.01)
    max_points: int = Field(6000, ge=100, le=1_000_000)
    max_ambiguity: float = Field(0.5, gt=0.0, le=1.0)
    max_rms_m: float = Field(1.0e-3, gt=0.0)
    max_predicted_tre_m: float = Field(1.0e-3, gt=0.0)
    min_inlier_fraction: float = Field(0.5, gt=0.0, le=1.0)


class Program(_Section):
    """The offline program: tool, approach and touch moves. The pointer (the screwer's tip)
    ends in a ball of 3 mm radius around its TCP: a `touch_offset_m` of 4 mm stops the ball
    1 mm before the entry, along the trajectory."""

    tool: Literal["screwer"] = "screwer"
    approach_m: float = Field(0.06, gt=0.0, le=0.3)
    touch_offset_m: float = Field(0.004, ge=0.0, le=0.05)
    touch_speed_m_s: float = Field(0.02, gt=0.0, le=0.5)
    spins: int = Field(12, ge=1, le=72)


class Calibration(_Section):
    """In-cell kinematic calibration before the scan (scenarios.offline.calibration): with the table
    at `table_position_m` [m], the laser views each reference sphere from `views_per_sphere`
    arm configurations, `lines_per_view` static lines each (averaged), from `standoff_m`
    (near, far) [m] with views tilted up to `max_tilt_deg` from the vertical. The run stops
    if the fit's residual RMS exceeds `max_residual_rms_m` [m]. `enabled: false` keeps the
    nominal kinematics."""

    enabled: bool = True
    table_position_m: float = Field(-0.25, ge=-0.5, le=0.5)
    views_per_sphere: int = Field(20, ge=4, le=100)
    lines_per_view: int = Field(10, ge=1, le=100)
    standoff_m: tuple[float, float] = (0.18, 0.32)
    max_tilt_deg: float = Field(55.0, ge=0.0, le=75.0)
    max_residual_rms_m: float = Field(1.0e-4, gt=0.0, le=0.01)

    @model_validator(mode="after")
    def _standoff_order(self) -> Calibration:
        near, far = self.standoff_m
        if not 0.06 <= near <= far <= 0.55:
            raise ValueError(
                f"standoff_m must be (near, far) with 0.06 <= near <= far <= 0.55 m (the "
                f"laser's range), got {self.standoff_m}"
            )
        return self


class Output(_Section):
    """What the run writes besides results.json and config.yaml."""

    rrd: bool = True
    plots: bool = True


class SkullConfig(_Section):
    """The skull job: scan, match, correct, touch the burr-hole entries, evaluate."""

    scenario: Literal["skull"] = "skull"
    seed: int = Field(0, ge=0)
    model: str = "skull"
    units: str = "mm"
    targets_file: str | None = None
    placement: Placement = Placement()
    noise: Noise = Noise()
    scan: Scan = Scan()
    registration: Registration = Registration()
    program: Program = Program()
    calibration: Calibration = Calibration()
    output: Output = Output()


class AssemblyConfig(_Section):
    """The assembly job: locate a part by IR edge probing (2D) and by surface matching (3D),
    pick it, change tool and drive its screws."""

    scenario: Literal["assembly"] = "assembly"
    seed: int = Field(0, ge=0)
    part: Literal["bracket"] = "bracket"  # the part with IR probe lines
    placement: Placement = Placement(
        yaw_deg=0.0, range_xy_m=0.015, range_yaw_deg=6.0, range_tilt_deg=0.0, lift_m=0.0
    )
    # A machined part differs from its CAD model by its tolerance (0.05 mm), not by a CT
    # segmentation's 0.3 mm.
    noise: Noise = Noise(model_deformation_rms_m=5.0e-5, model_noise_rms_m=2.0e-5)
    # From above, the L-bracket's two legs (50 and 56 mm) nearly swap under a half turn and
    # the part could slide along its length: the side passes see its L-shaped end faces, and
    # the search runs without the 2D pose (an independent method).
    scan: Scan = Scan(
        standoff_m=0.25,
        passes=(
            ScanPass(tilt_deg=0.0, offset_m=0.0),
            ScanPass(tilt_deg=30.0, offset_m=-0.03),
            ScanPass(tilt_deg=45.0, heading_deg=90.0),
            ScanPass(tilt_deg=45.0, heading_deg=-90.0),
        ),
        min_points=3000,
    )
    # One point per 1 mm cube: the end faces and the hole rims that tell the bracket's
    # pose apart are a few millimetres wide.
    registration: Registration = Registration(voxel_m=0.001, max_points=4000)
    calibration: Calibration = Calibration()
    touch_offset_m: float = Field(0.004, ge=0.0, le=0.05)
    probe_height_m: float = Field(0.03, gt=0.01, le=0.1)
    output: Output = Output()


class PaperConfig(_Section):
    """The seed paper's experiments on the ellipsoid."""

    scenario: Literal["paper"] = "paper"
    seed: int = Field(0, ge=0)


Config = SkullConfig | AssemblyConfig | PaperConfig
_KINDS: dict[str, type[BaseModel]] = {
    "skull": SkullConfig,
    "assembly": AssemblyConfig,
    "paper": PaperConfig,
}


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


def read_yaml_mapping(path: Path, error: type[Exception] = ConfigError) -> dict[str, Any]:
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


def parse_config(data: dict[str, Any], source: str = "config") -> Config:
    """Validate a configuration mapping; its `scenario` key picks the kind."""
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: a configuration must be a mapping, got {type(data).__name__}")
    kind = data.get("scenario")
    if kind not in _KINDS:
        raise ConfigError(f"{source}: 'scenario' must be one of {sorted(_KINDS)}, got {kind!r}")
    try:
        return _KINDS[kind].model_validate(data)  # type: ignore[return-value]
    except ValidationError as exc:
        raise ConfigError(f"{source}: {describe_validation_error(exc)}") from None


def load_config(name_or_path: str | Path, overrides: dict[str, Any] | None = None) -> Config:
    """A shipped configuration by name or a YAML file by path, with `overrides` (top-level
    keys such as seed, model, units) applied before validation."""
    text = str(name_or_path)
    path = Path(text)
    if text in shipped_names():
        path = CONFIG_DIR / f"{text}.yaml"
    elif path.suffix not in (".yaml", ".yml"):
        raise ConfigError(
            f"unknown scenario {text!r}; shipped: {', '.join(shipped_names())}, or give a "
            f".yaml file"
        )
    data = {**read_yaml_mapping(path), **(overrides or {})}
    return parse_config(data, str(path))


def config_yaml(config: Config) -> str:
    """The resolved configuration as YAML (every key, defaults included)."""
    return yaml.safe_dump(config.model_dump(mode="json"), sort_keys=False)
