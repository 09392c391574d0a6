"""The cell's sections of a job configuration: the robot, the object and how it is placed, the
real cell's error sources (the truth the simulation is built from; no stage reads them), and
where the virtual model comes from."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import (
    AwareDatetime,
    Field,
    field_validator,
    model_validator,
)

from cell.robots import BUILTIN
from scenarios.offline.laser_sheet import LaserSection
from scenarios.offline.settings import (
    FixtureTolerance,
    NominalPlacement,
    Section,
)


class Placement(NominalPlacement):
    """Where the object sits on the table: the nominal pose (what the planner believes,
    scenarios.offline.settings.NominalPlacement) and the ranges the real one is drawn from
    around it by the run's seed (the truth; no stage reads them). The table frame is the top's
    centre, x away from the built-in arm (at the cell's origin), z up: (1.15, 0, 0.4) m in the
    cell at table position 0, the top 800 x 600 mm. The mesh's origin stands over `xy_m` [m]
    (default the top's centre), turned in this order about the table's axes: its `up_axis` (the
    mesh's axis that points up, away from the table: `+x`, `-x`, `+y`, `-y`, `+z`, `-z`; default
    `+z`, the mesh as modelled) turned up, then `roll_deg` about x, `pitch_deg` about y,
    `yaw_deg` about the vertical (R_table_object = Rz(yaw) Ry(pitch) Rx(roll) R_up); it rests
    with its lowest point `lift_m` [m] above the top (default 4 mm). The real pose is moved
    within +-`range_xy_m` [m] in x and y, turned within +-`range_yaw_deg` about the vertical and
    tilted within +-`range_tilt_deg` about a random horizontal axis (its roll and pitch alike),
    still resting on the table. `twincell model PART --up-axis ...` shows how a part lies."""

    range_xy_m: float = Field(0.03, ge=0.0, le=0.2)
    range_yaw_deg: float = Field(20.0, ge=0.0, le=180.0)
    range_tilt_deg: float = Field(5.0, ge=0.0, le=30.0)


class DriveNoise(Section):
    """The arm's drives beyond its kinematics (cell.sim.config.DriveErrors, where the defaults'
    sources are): joint 2 and 3 stiffness [N m/rad] (0: rigid) and its spread, lost motion
    per joint [rad], pose repeatability [rad], thermal zero drift of joints 2 and 3 [rad/s];
    each joint's zero shift once warm [rad], the warm-up's time constant [s] and how long the
    arm has run when the job starts [s]."""

    stiffness_nm_rad: tuple[float, float] = (1.5e6, 1.0e6)
    stiffness_spread: float = Field(0.1, ge=0.0, le=1.0)
    hysteresis_rad: tuple[float, float, float, float, float, float] = (
        2e-5, 2e-5, 2e-5, 4e-5, 4e-5, 4e-5
    )  # fmt: skip
    repeat_sigma_rad: float = Field(1.0e-5, ge=0.0, le=0.01)
    drift_rad_per_s: tuple[float, float] = (0.0, 0.0)
    warmup_rad: tuple[float, float, float, float, float, float] = (0.0,) * 6
    warmup_tau_s: float = Field(1800.0, gt=0.0, le=86400.0)
    warm_s: float = Field(0.0, ge=0.0)


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
    """Error sources of the real cell and of the model. `draw` is which draw of the cell's
    run-to-run noise a run meets (its sensors', the table's repeatability, the moves'): 0 is
    the seed's own, another number the same real cell, its object placed as it was, run
    again. `arm_thermal_strain`: how much the arm's links have grown (dL/L) since the
    temperature its kinematic errors were drawn at (a shift sets it from the arm's warmth
    and the ambient's change; 0: none)."""

    laser_sigma_m: float = Field(1.0e-4, ge=0.0, le=0.01)
    arm_length_sigma_m: float = Field(1.5e-4, ge=0.0, le=0.01)
    arm_offset_sigma_rad: float = Field(1.0e-4, ge=0.0, le=0.01)
    arm_thermal_strain: float = Field(0.0, ge=-1.0e-3, le=1.0e-3)
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
    draw: int = Field(0, ge=0)


class ObjectSection(Section):
    """The object of the job: a built-in model (`skull`, `bracket`, `housing`, `lid`,
    `ellipsoid`), a mesh file in `units`, or a CT volume (a DICOM series folder, NIfTI or
    NRRD: its bone at `model.ct.iso_hu`), `fixed` on the table or lying `loose` on it (a
    part the gripper picks), at a pose drawn around the nominal one. Its operation targets
    come from the model (burr holes, screw frames), from `targets_file` (for a CT volume, a
    JSON plan made on it: models.ct.volume_plan), from a `<mesh>.targets.yaml` beside a mesh file,
    or are generated on its upper surface. `draw` is which of the seed's placements the run
    meets: 0 is the seed's own, another number the same real cell with the object placed anew
    (the next part of a shift, `twincell shift`)."""

    model: str = "skull"
    units: Literal["m", "mm"] = "mm"
    fixing: Literal["fixed", "loose"] = "fixed"
    placement: Placement = Placement()
    tolerance: FixtureTolerance = FixtureTolerance()
    targets_file: str | None = None
    draw: int = Field(0, ge=0)


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
    slots 0.25 m apart along x from it and 0.8 m above it), its laser, the object, and the
    error sources of the real cell and of the model. `clock_utc`: the simulated cell's
    controller clock as the job starts (ISO 8601 with its zone: a shift's jobs run on the
    shift's clock, so that a saved calibration ages with the shift); none: this computer's
    clock."""

    robot: RobotSection = RobotSection()
    rack_xyz: tuple[float, float, float] = (0.0, -0.85, 0.0)
    laser: LaserSection = LaserSection()
    object: ObjectSection = ObjectSection()
    noise: Noise = Noise()
    clock_utc: AwareDatetime | None = None


class CTSection(Section):
    """The simulated CT of the real object (`model.source: ct`; models.ct.ct_scanner): voxel size
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
