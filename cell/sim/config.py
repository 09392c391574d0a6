"""The real cell's configuration: its layout (cell.layout) with the error sources that the
simulation draws, and the faults it will have.

Every error source has its own frozen dataclass and can be set to zero (`CellConfig.ideal()`).
Values are SI: [m], [rad].
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from datetime import datetime

import numpy as np

from cell.cell_errors import CellConfigError
from cell.irb2400_arm import irb2400
from cell.layout import (
    CellLayout,
    FixedMesh,
    FixedPrimitive,
    IRConfig,
    LaserConfig,
    LooseMesh,
    LoosePart,
    nonneg,
)
from cell.robot_arm import Robot
from cell.sim.faults import Fault
from models.robot import RACK_POS


@dataclass(frozen=True)
class ArmErrors:
    """Kinematic deviations of the real arm from its nominal model (drawn once per cell).

    `length_sigma_m` per length deviation (the built-in arm's six link lengths; another arm's
    joint axis positions) and `offset_sigma_rad` per joint zero offset (see cell.robot_arm).
    The defaults give an industrial arm's absolute accuracy, about 0.2-0.5 mm at the TCP.
    `thermal_strain`: the links' growth (dL/L) since the temperature the arm's deviations
    hold at (cell.robot_arm.Robot.grown; 0: none), for the whole run.
    """

    length_sigma_m: float = 1.5e-4
    offset_sigma_rad: float = 1.0e-4
    thermal_strain: float = 0.0

    def __post_init__(self) -> None:
        nonneg(
            "ArmErrors", length_sigma_m=self.length_sigma_m, offset_sigma_rad=self.offset_sigma_rad
        )


@dataclass(frozen=True)
class DriveErrors:
    """The arm's drives between the motors (where the encoders are) and the links: what makes
    a real arm miss beyond its kinematic parameters. Each can be set to zero.

    - `stiffness_nm_rad` (joints 2, 3): gearbox torsional stiffness [N m/rad]; the links sag
      by the gravity torque of the arm and its payload over it (0: rigid). The real value is
      the nominal one times 1 + N(0, `stiffness_spread`). Default: 1.5e6 and 1.0e6 N m/rad,
      the order measured on industrial arms' joints 2 and 3 (Dumas et al., Joint stiffness
      identification of six-revolute industrial serial robots, Robotics and Computer-
      Integrated Manufacturing 27(4), 2011), giving 0.05-0.3 mm of sag at this arm's TCP.
    - `hysteresis_rad` (6,): lost motion per joint; the link stops half of it behind the
      motor, on the side it came from. Default 20 urad on the main axes and 40 urad on the
      wrist (4-8 arcsec: a precision cycloidal gear's lost motion seen through the motor's
      encoder after the controller's backlash compensation).
    - `repeat_sigma_rad`: per joint, where a pose reached again lands (redrawn each move).
      Default 1e-5 rad: about 0.03-0.06 mm at the TCP (3 sigma), the pose repeatability of an
      IRB 2400 (0.03-0.06 mm, ABB's product specification).
    - `drift_rad_per_s` (joints 2, 3): zero drift as the arm warms up (thermal growth),
      off by default; 1e-8 rad/s is about 0.04 mm an hour at the TCP.
    - `warmup_rad` (6,): each joint's zero shift once the arm is warm (motor less link
      [rad]), approached as 1 - exp(-t / `warmup_tau_s`) over the time t the arm has run:
      `warm_s` when this cell's clock starts, plus the cell's time. Off by default. A
      warm-up moves an arm's tool by tenths of a millimetre: an IRB 1200's repeatability
      differed cold and warm by up to an order of magnitude over its 0.025 mm (Appl. Sci.
      2021, 11(22), 10813), and a small arm's total drift over a 20 K swing stayed under
      0.2 mm after a 30 min warm-up (ST Robotics' repeatability test). Here 5e-4 rad at
      joints 2 and 3 moved the calibration spheres 0.6 mm and the skull's targets about 1 mm
      (seed 5).
    """

    stiffness_nm_rad: tuple[float, float] = (1.5e6, 1.0e6)
    stiffness_spread: float = 0.1
    hysteresis_rad: tuple[float, ...] = (2e-5, 2e-5, 2e-5, 4e-5, 4e-5, 4e-5)
    repeat_sigma_rad: float = 1.0e-5
    drift_rad_per_s: tuple[float, float] = (0.0, 0.0)
    warmup_rad: tuple[float, ...] = (0.0,) * 6
    warmup_tau_s: float = 1800.0
    warm_s: float = 0.0

    def __post_init__(self) -> None:
        if len(self.stiffness_nm_rad) != 2 or len(self.drift_rad_per_s) != 2:
            raise CellConfigError(
                "DriveErrors.stiffness_nm_rad and drift_rad_per_s take joints 2 and 3 (two "
                f"values), got {self.stiffness_nm_rad!r}, {self.drift_rad_per_s!r}"
            )
        if len(self.hysteresis_rad) != 6 or len(self.warmup_rad) != 6:
            raise CellConfigError(
                "DriveErrors.hysteresis_rad and warmup_rad take six values, got "
                f"{self.hysteresis_rad!r}, {self.warmup_rad!r}"
            )
        if not (self.warmup_tau_s > 0.0 and self.warm_s >= 0.0):
            raise CellConfigError(
                f"DriveErrors.warmup_tau_s must be > 0 and warm_s >= 0 [s], got "
                f"{self.warmup_tau_s!r}, {self.warm_s!r}"
            )
        nonneg(
            "DriveErrors",
            stiffness_spread=self.stiffness_spread,
            repeat_sigma_rad=self.repeat_sigma_rad,
            **{f"stiffness_{j}": v for j, v in zip((2, 3), self.stiffness_nm_rad, strict=True)},
            **{f"hysteresis_{j + 1}": v for j, v in enumerate(self.hysteresis_rad)},
        )
        if not all(np.isfinite(self.drift_rad_per_s)):
            raise CellConfigError(
                f"DriveErrors.drift_rad_per_s must be finite, got {self.drift_rad_per_s!r}"
            )

    @classmethod
    def off(cls) -> DriveErrors:
        """Rigid, exact drives: the links where the motors are."""
        return cls((0.0, 0.0), 0.0, (0.0,) * 6, 0.0, (0.0, 0.0), (0.0,) * 6)

    @property
    def rigid(self) -> bool:
        """No compliance, no lost motion, no repeatability spread, no drift."""
        return (
            not any(self.stiffness_nm_rad)
            and not any(self.hysteresis_rad)
            and self.repeat_sigma_rad == 0.0
            and not any(self.drift_rad_per_s)
            and not any(self.warmup_rad)
        )


@dataclass(frozen=True)
class ToolErrors:
    """The tools' true TCPs and how they seat on the flange.

    - `tcp_sigma_m`, `tcp_sigma_rad`: each tool's TCP off its nominal tooldata (drawn once:
      manufacturing). Default 0.05 mm and 0.25 mrad: ISO 2768-f (fine) general tolerances,
      +-0.15 mm over 30-120 mm as 3 sigma, and that much across the 0.2 m of the pointer.
    - `changer_sigma_m`, `changer_sigma_rad`: where a tool seats at each lock (redrawn at
      every tool change). Default 5 um and 20 urad: tool changers' repeatability of
      +-0.015 mm (3 sigma; ATI QC and SCHUNK SWS data sheets give +-0.01 to +-0.015 mm).
    - `laser_mount_sigma_m`, `laser_mount_sigma_rad`: the laser's optical frame off its
      nominal mounting on the tool plate (hand-eye), drawn once. Default 0.2 mm and 2 mrad.
    - `laser_scale_sigma`: the laser's range scale error (relative, drawn once). Default
      3e-4: a line scanner's linearity of 0.01-0.1 % of its measuring range.
    """

    tcp_sigma_m: float = 5.0e-5
    tcp_sigma_rad: float = 2.5e-4
    changer_sigma_m: float = 5.0e-6
    changer_sigma_rad: float = 2.0e-5
    laser_mount_sigma_m: float = 2.0e-4
    laser_mount_sigma_rad: float = 2.0e-3
    laser_scale_sigma: float = 3.0e-4

    @classmethod
    def off(cls) -> ToolErrors:
        """Every tool at its nominal TCP, seated exactly; the laser exact."""
        return cls(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        nonneg(
            "ToolErrors",
            tcp_sigma_m=self.tcp_sigma_m,
            tcp_sigma_rad=self.tcp_sigma_rad,
            changer_sigma_m=self.changer_sigma_m,
            changer_sigma_rad=self.changer_sigma_rad,
            laser_mount_sigma_m=self.laser_mount_sigma_m,
            laser_mount_sigma_rad=self.laser_mount_sigma_rad,
            laser_scale_sigma=self.laser_scale_sigma,
        )


@dataclass(frozen=True)
class EncoderNoise:
    """Gaussian noise [rad] on every joint reading (encoders and the laser's joint stamp)."""

    sigma_rad: float = 1.0e-5

    def __post_init__(self) -> None:
        nonneg("EncoderNoise", sigma_rad=self.sigma_rad)


@dataclass(frozen=True)
class TableErrors:
    """Errors of the linear axis; its readout sees none of them.

    - `bias_sigma_m`: a constant positioning error drawn once; `repeat_sigma_m`: per move.
    - `straightness_sigma_m`: the carriage's sideways (x) and vertical (z) deviation from a
      straight travel, a bow over the travel whose amplitude is drawn once per direction.
    - `pitch_sigma_rad`, `yaw_sigma_rad`: the carriage's tilt about x and turn about z,
      varying linearly over the travel (its end values drawn once).
    Defaults (20 um, 25 urad): a precision linear guide over a metre of travel (ISO 230-1
    terms; about 5 arcsec of pitch and yaw and 0.02 mm of straightness).
    """

    bias_sigma_m: float = 1.0e-4
    repeat_sigma_m: float = 1.0e-5
    straightness_sigma_m: float = 2.0e-5
    pitch_sigma_rad: float = 2.5e-5
    yaw_sigma_rad: float = 2.5e-5

    def __post_init__(self) -> None:
        nonneg(
            "TableErrors",
            bias_sigma_m=self.bias_sigma_m,
            repeat_sigma_m=self.repeat_sigma_m,
            straightness_sigma_m=self.straightness_sigma_m,
            pitch_sigma_rad=self.pitch_sigma_rad,
            yaw_sigma_rad=self.yaw_sigma_rad,
        )


@dataclass(frozen=True)
class CellConfig:
    """Everything that defines a simulated cell: its `robot` (cell.robot_arm), where its tool
    rack stands (`rack_xyz` [m], the rack frame; the slots are 0.25 m apart along x and 0.8 m
    above it), the error sources, the objects on the table, the faults it will have
    (cell.sim.faults). `seed` draws the real cell's errors; `noise_draw` its run-to-run noise
    (its sensors', the table's repeatability, the moves'), 0 being the seed's own draw.
    `clock_start_utc`: the controller's date and time as the simulation starts (None: its
    clock is this computer's); it draws nothing."""

    seed: int = 0
    noise_draw: int = 0
    robot: Robot = field(default_factory=irb2400)
    rack_xyz: tuple[float, float, float] = RACK_POS
    arm: ArmErrors = field(default_factory=ArmErrors)
    drives: DriveErrors = field(default_factory=DriveErrors)
    tools: ToolErrors = field(default_factory=ToolErrors)
    encoder: EncoderNoise = field(default_factory=EncoderNoise)
    table: TableErrors = field(default_factory=TableErrors)
    laser: LaserConfig = field(default_factory=LaserConfig)
    ir: IRConfig = field(default_factory=IRConfig)
    fixtures: tuple[FixedMesh | FixedPrimitive, ...] = ()
    parts: tuple[LoosePart | LooseMesh, ...] = ()
    faults: tuple[Fault, ...] = ()
    clock_start_utc: datetime | None = None

    def __post_init__(self) -> None:
        self.layout()  # checks the rack and the objects
        if self.clock_start_utc is not None and self.clock_start_utc.tzinfo is None:
            raise CellConfigError(
                f"clock_start_utc {self.clock_start_utc.isoformat()} gives no time zone: "
                "give an aware date and time (UTC)"
            )

    def layout(self) -> CellLayout:
        """The cell's layout: the arm, the rack, the laser, the objects (no error source)."""
        return CellLayout(self.robot, self.rack_xyz, self.laser, self.fixtures, self.parts)

    def ideal(self) -> CellConfig:
        """The same cell with every error source set to zero (the nominal cell)."""
        return replace(
            self,
            arm=ArmErrors(0.0, 0.0),
            drives=DriveErrors.off(),
            tools=ToolErrors.off(),
            encoder=EncoderNoise(0.0),
            table=TableErrors(0.0, 0.0, 0.0, 0.0, 0.0),
            laser=replace(self.laser, sigma_m=0.0, dropout=0.0),
            ir=replace(self.ir, sigma_m=0.0),
            faults=(),
        )
