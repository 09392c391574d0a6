"""The planning settings: what the stages that plan, scan, localize, calibrate, program,
verify and execute are told, validated by pydantic (an unknown key or a bad value is named).

These are the sections of a job's configuration (scenarios.configuration) that belong to the
planner: the scan and its planning, the registration's acceptance, the calibration and its
priors, the probing, the operations and the pick, the verification, and what the planner
believes of the object's placement: its nominal pose and the fixture's tolerance (a data
sheet's number). Nothing here says how the real cell errs: its noise, its faults and the
ranges the simulation draws the real placement from are the job's (scenarios.configuration).
Values are SI ([m], [rad] where the key says so, degrees only in keys ending in `_deg`).
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator
from pydantic_core import PydanticCustomError

from scenarios.offline.laser_sheet import LaserSection


class Section(BaseModel):
    """A section of a configuration: frozen, and an unknown key is an error."""

    model_config = ConfigDict(extra="forbid", frozen=True)


#: The axes a model's up axis may be: the one that points up, away from the table.
UP_AXES: tuple[str, ...] = ("+x", "-x", "+y", "-y", "+z", "-z")
UpAxis = Literal["+x", "-x", "+y", "-y", "+z", "-z"]


class NominalPlacement(Section):
    """Where the planner believes the object sits on the table: `xy_m` [m] of its origin in
    the table frame, resting on the table with its lowest point `lift_m` [m] above the top
    (a fixture's pins). Its orientation, in this order, about the table's axes: the model's
    `up_axis` (the axis of the mesh that points up, away from the table) turned up, then
    `roll_deg` about x, `pitch_deg` about y, `yaw_deg` about the vertical z
    (R_table_object = Rz(yaw) Ry(pitch) Rx(roll) R_up; scenarios.offline.nominal_placement).
    The default heading (120 degrees) turns the skull's face 60 degrees from the robot, where
    the screwer reaches every burr hole without folding into the forearm."""

    xy_m: tuple[float, float] = (0.0, 0.0)
    up_axis: UpAxis = "+z"
    roll_deg: float = Field(0.0, ge=-180.0, le=180.0)
    pitch_deg: float = Field(0.0, ge=-180.0, le=180.0)
    yaw_deg: float = 120.0
    lift_m: float = Field(0.004, ge=0.0, le=0.1)

    @field_validator("up_axis", mode="before")
    @classmethod
    def _known_axis(cls, value: Any) -> Any:
        if value not in UP_AXES:
            raise PydanticCustomError(
                "up_axis",
                "the model's axis that points up, away from the table, is one of "
                + ", ".join(UP_AXES),
            )
        return value


class FixtureTolerance(Section):
    """How far the fixture lets the object sit from its nominal pose, as its drawing or data
    sheet gives it: sideways per axis [m], about the vertical and tilted about any horizontal
    axis from its nominal orientation (whatever its up axis, roll and pitch) [deg]. The
    planner's prior: what its clearances (the calibration's views keep off the object) allow
    for."""

    xy_m: float = Field(0.03, ge=0.0, le=0.2)
    yaw_deg: float = Field(20.0, ge=0.0, le=180.0)
    tilt_deg: float = Field(5.0, ge=0.0, le=30.0)


class ScanPass(Section):
    """One straight laser pass. With `heading_deg` 0: the laser looks down, tilted by
    `tilt_deg` about the table's y axis (positive: towards +x, away from the robot), aimed
    `offset_m` along x from the object's centre, and the sweep runs along y over the object's
    width plus `margin_m`. `heading_deg` turns all of that about the table's vertical (90:
    the laser looks towards +y and sweeps along x). `standoff_m`: the laser's distance from
    the object's nominal box along its view [m] (None: the scan's `standoff_m`)."""

    tilt_deg: float = Field(0.0, ge=-75.0, le=75.0)
    offset_m: float = Field(0.0, ge=-0.5, le=0.5)
    heading_deg: float = Field(0.0, ge=-180.0, le=180.0)
    standoff_m: float | None = Field(None, gt=0.05, le=0.6)


class ScanPlanning(Section):
    """How `plan: auto` chooses its passes (scenarios.offline.scan_plan): candidates at the
    tilts [deg] from above to the sides and the headings [deg] about the vertical; passes
    are added until every target's predicted TRE is below `goal_tre_m` [m] or the scan's
    cell time reaches `budget_s` [s]. Each candidate is tried at the scan's stand-off and at
    each of `extra_standoffs_m` [m] farther (negative: nearer; a farther laser's fan covers
    more of the object per line). The predicted errors are data-sheet numbers: the
    laser's range noise [m], the object's deviation from its model [m] and that deviation's
    correlation length [m] (a moulded phantom or a machined part: about 0.2 mm over 2 cm)."""

    tilts_deg: tuple[float, ...] = (0.0, 30.0, 50.0, 70.0)
    headings_deg: tuple[float, ...] = (0.0, 45.0, 90.0, 135.0, 180.0, -135.0, -90.0, -45.0)
    extra_standoffs_m: tuple[float, ...] = ()
    goal_tre_m: float = Field(3.0e-4, gt=0.0, le=0.01)
    budget_s: float = Field(120.0, gt=0.0, le=3600.0)
    #: Short of the goal, passes are added only while one lowers the worst predicted TRE by
    #: at least this fraction of it; a plan that stops short is scanned if the match would
    #: accept its prediction (registration.max_predicted_tre_m), and refused otherwise.
    min_gain: float = Field(0.02, ge=0.0, lt=1.0)
    range_sigma_m: float = Field(1.0e-4, ge=0.0, le=0.01)
    model_error_m: float = Field(2.0e-4, ge=0.0, le=0.01)
    correlation_m: float = Field(0.02, gt=0.0, le=1.0)
    #: The chosen passes' sweep speed [m/s]; None: lines one registration voxel apart
    #: (voxel / line period, at most 0.5 m/s): the match keeps one point per voxel, so
    #: closer lines add time and no information.
    sweep_speed_m_s: float | None = Field(None, gt=0.0, le=0.5)

    @field_validator("extra_standoffs_m")
    @classmethod
    def _standoffs(cls, v: tuple[float, ...]) -> tuple[float, ...]:
        if any(not -0.2 <= d <= 0.3 or d == 0.0 for d in v):
            raise ValueError(
                "extra_standoffs_m must be non-zero distances in [-0.2, 0.3] m (the scan's own "
                "stand-off is always a candidate)"
            )
        return v

    @field_validator("tilts_deg", "headings_deg")
    @classmethod
    def _angles(cls, v: tuple[float, ...], info: Any) -> tuple[float, ...]:
        limit = 75.0 if info.field_name == "tilts_deg" else 180.0
        if not v or any(not -limit <= a <= limit for a in v):
            raise ValueError(
                f"{info.field_name} must be a non-empty list in [-{limit:g}, {limit:g}]"
            )
        return v


class Raster(Section):
    """A point laser's pass (`cell.laser.kind: point`): its one ray swept along parallel
    lines `step_m` [m] apart across the pass, over `half_width_m` [m] either side of the
    line a line laser's pass would sweep, each line run back the way the last one came. A
    line laser's fan covers that width in one line."""

    step_m: float = Field(0.005, ge=5.0e-4, le=0.05)
    half_width_m: float = Field(0.05, ge=0.0, le=0.3)


class Scan(Section):
    """The scan plan's parameters: the laser's stand-off [m], sweep speed [m/s] and line
    period [s], the sweep's margin beyond the object's nominal footprint [m], the passes; the
    points kept as the object's are those above the table within its nominal footprint
    enlarged by `crop_margin_m` [m] (how far the object may lie from where it is believed to
    be), and the scan must keep at least `min_points` of them. `plan`: "fixed" scans the
    passes; "auto" chooses them in the virtual cell for the targets (`planning`)."""

    standoff_m: float = Field(0.28, gt=0.05, le=0.6)
    speed_m_s: float = Field(0.1, gt=0.0, le=0.5)
    period_s: float = Field(0.01, ge=0.002, le=0.5)
    margin_m: float = Field(0.04, ge=0.0, le=0.3)
    crop_margin_m: float = Field(0.06, ge=0.0, le=0.3)
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
    #: "auto" (default): passes chosen in the virtual cell for the targets (`planning`);
    #: "fixed": the passes above.
    plan: Literal["fixed", "auto"] = "auto"
    planning: ScanPlanning = ScanPlanning()
    raster: Raster = Raster()


class Registration(Section):
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


class CalibrationPriorsSection(Section):
    """What the data sheets say before the calibration (scenarios.offline.
    calibration_identification.CalibrationPriors): the arm's kinematic parameters [m, rad],
    its joint 2 and 3 stiffness [N m/rad] and its relative spread, the laser's mounting
    [m, rad] and range linearity, where the table stops beyond its readout [m] and its
    guideway's angles [rad], the laser's range noise [m]. Never the simulated cell's own
    figures."""

    length_sigma_m: float = Field(1.0e-3, gt=0.0, le=0.1)
    offset_sigma_rad: float = Field(1.0e-3, gt=0.0, le=0.1)
    stiffness_nm_rad: tuple[float, float] = (1.5e6, 1.0e6)
    stiffness_spread: float = Field(0.3, gt=0.0, le=10.0)
    laser_mount_sigma_m: float = Field(1.0e-3, gt=0.0, le=0.1)
    laser_mount_sigma_rad: float = Field(1.0e-2, gt=0.0, le=1.0)
    laser_scale_sigma: float = Field(1.0e-3, gt=0.0, le=0.1)
    table_station_sigma_m: float = Field(5.0e-5, gt=0.0, le=0.01)
    table_angle_sigma_rad: float = Field(1.0e-4, gt=0.0, le=0.01)
    point_sigma_m: float = Field(1.0e-4, gt=0.0, le=0.01)


class Calibration(Section):
    """In-cell calibration before the scan (scenarios.offline.calibration): at each of
    `table_positions_m` [m] the laser views each reference sphere from about
    `views_per_sphere` / (number of positions) arm configurations, `lines_per_view` static
    lines each (averaged), from `standoff_m` (near, far) [m] with views tilted up to
    `max_tilt_deg` from the vertical. `identify` names what is fitted (`arm`, always; the
    joints' `stiffness`; the `laser`'s mounting and scale; the `table` axis), each held by its
    data-sheet prior (`priors`). The run stops if the fit's residual RMS exceeds
    `max_residual_rms_m` [m]. `enabled: false` keeps the data sheet's cell. `latency`: the
    latency of a laser whose lines are paired with the arm's pose by time (a controller
    across the network): `identify` (on a sphere swept both ways at two speeds,
    scenarios.offline.laser_latency), or a number [s], the sensor's data sheet's, used as
    it is. A saved calibration a job starts from (`twincell run --calibration FILE`) is at
    most `max_age_h` old [h]; the job checks it first, viewing each sphere from
    `check_views` poses, and calibrates anew where the spheres' largest shift since, at its
    95 % upper bound, exceeds `check_tolerance_m` [m] (None: 30 % of the job's RMS goal, a
    drift that adds under 5 % to it in quadrature; 0.1 mm without a goal); with `given: keep`
    it takes the saved calibration as it is, unchecked (a cell calibrated once)."""

    enabled: bool = True
    max_age_h: float = Field(24.0, gt=0.0)
    given: Literal["check", "keep"] = "check"
    check_views: int = Field(6, ge=3, le=48)
    check_tolerance_m: float | None = Field(None, gt=0.0, le=0.01)
    latency: Literal["identify"] | Annotated[float, Field(ge=-0.5, le=0.5)] = "identify"
    table_positions_m: tuple[float, ...] = Field((-0.45, -0.25, -0.05), min_length=1)
    views_per_sphere: int = Field(48, ge=4, le=200)
    lines_per_view: int = Field(10, ge=1, le=100)
    standoff_m: tuple[float, float] = (0.18, 0.32)
    max_tilt_deg: float = Field(55.0, ge=0.0, le=75.0)
    max_residual_rms_m: float = Field(1.0e-4, gt=0.0, le=0.01)
    identify: tuple[Literal["arm", "stiffness", "laser", "table"], ...] = (
        "arm",
        "stiffness",
        "laser",
        "table",
    )
    priors: CalibrationPriorsSection = CalibrationPriorsSection()

    @model_validator(mode="after")
    def _check(self) -> Calibration:
        near, far = self.standoff_m
        if not 0.06 <= near <= far <= 0.55:
            raise ValueError(
                f"standoff_m must be (near, far) with 0.06 <= near <= far <= 0.55 m (the "
                f"laser's range), got {self.standoff_m}"
            )
        if not all(-0.5 <= s <= 0.5 for s in self.table_positions_m):
            raise ValueError(
                f"table_positions_m must be within the table's travel [-0.5, 0.5] m, got "
                f"{list(self.table_positions_m)}"
            )
        if "arm" not in self.identify:
            raise ValueError(f"identify must include 'arm', got {list(self.identify)}")
        return self


class Probe(Section):
    """2D adjusting by IR edge probing: the IR sensor looks down from `height_m` [m] above the
    table along the probe lines that the part's model defines."""

    height_m: float = Field(0.03, gt=0.01, le=0.1)


class LocalizationSection(Section):
    """How the object is located: `methods` in order, each of `surface` (laser scan matched
    to the virtual model) and `probe` (IR edge probing, position and heading only); the first
    one's pose drives the program, the others are run side by side for comparison."""

    methods: tuple[Literal["surface", "probe"], ...] = Field(("surface",), min_length=1)
    scan: Scan = Scan()
    registration: Registration = Registration()
    probe: Probe = Probe()

    @model_validator(mode="after")
    def _distinct(self) -> LocalizationSection:
        if len(set(self.methods)) != len(self.methods):
            raise ValueError(f"methods must not repeat, got {list(self.methods)}")
        return self


class Pick(Section):
    """A pick before the operations: the gripper takes the part at its operation frame
    `frame` (turned `turn_deg` about its z so that the fingers close across it), lifts it
    `lift_m` [m] at `speed_m_s`, holds it `hold_s` [s], puts it down where it took it and
    opens to `open_m` [m]."""

    frame: str = "grasp"
    turn_deg: float = Field(90.0, ge=-180.0, le=180.0)
    approach_m: float = Field(0.08, gt=0.0, le=0.3)
    lift_m: float = Field(0.04, ge=0.0, le=0.2)
    speed_m_s: float = Field(0.05, gt=0.0, le=0.5)
    hold_s: float = Field(1.0, ge=0.0, le=10.0)
    open_m: float = Field(0.03, gt=0.0, le=0.08)


class OperationsSection(Section):
    """What the program does at each target of the object, with `tool`:
    - `touch`: the tool tip stops `touch_offset_m` [m] before the target's entry, along its
      axis (the pointer touching a burr-hole entry);
    - `screw`: the same, then the screwer spins `screw_speed_rad_s` for `screw_s`.
    Each starts from `approach_m` back along the axis and moves there at `touch_speed_m_s`;
    the tool may spin about its axis (`spins` tried) for reach. `per_method: true` runs the
    operations once with each localization method's pose (to compare them); otherwise with
    the first method's. An optional `pick` comes first (with the first method's pose).

    The targets come from the object's model, or from the user's own RAPID module
    (`program`, a .mod file written for the virtual cell, e.g. in RobotStudio): the
    robtargets of its work object `wobj` (default: the one its moves use), approach and
    touch recognised from the MoveJ/MoveL pattern or listed in `pairs` ([approach, touch]
    target names); the robtargets are the touch poses themselves (no touch offset). The run
    writes that module back corrected: only the work object's oframe changes. `names`: what
    the program's targets are called in the results: `robtargets` (the touch robtargets'
    names, `pTouch0`), `comments` (the one word of a comment line `! kocher_right` right above
    a touch's approach move, else the robtarget's name) or a table {robtarget: name} (the
    robtargets not in it keep their names)."""

    kind: Literal["touch", "screw"] = "touch"
    tool: str = "screwer"
    approach_m: float = Field(0.06, gt=0.0, le=0.3)
    touch_offset_m: float = Field(0.004, ge=0.0, le=0.05)
    touch_speed_m_s: float = Field(0.02, gt=0.0, le=0.5)
    spins: int = Field(12, ge=1, le=72)
    screw_speed_rad_s: float = Field(20.0, gt=0.0, le=200.0)
    screw_s: float = Field(0.5, ge=0.0, le=10.0)
    per_method: bool = False
    pick: Pick | None = None
    program: str | None = None
    wobj: str | None = None
    pairs: tuple[tuple[str, str], ...] | None = None
    names: Literal["robtargets", "comments"] | dict[str, str] = "robtargets"

    @field_validator("tool")
    @classmethod
    def _known_tool(cls, tool: str) -> str:
        from models.robot import TOOLS

        names = [t.name for t in TOOLS]
        if tool not in names:
            raise ValueError(f"tool must be one of the cell's tools {names}")
        return tool

    @model_validator(mode="after")
    def _program_keys(self) -> OperationsSection:
        if self.program is None and (
            self.wobj is not None or self.pairs is not None or self.names != "robtargets"
        ):
            raise ValueError("wobj, pairs and names belong to a RAPID program: set program too")
        return self

    @model_validator(mode="after")
    def _screwer_screws(self) -> OperationsSection:
        if self.kind == "screw" and self.tool != "screwer":
            raise ValueError(f"screw operations need the screwer, got tool {self.tool!r}")
        return self


class BudgetCoverage(Section):
    """The error budget's coverage factors (scenarios.offline.error_budget): a target's bound is
    its standard error times `k_target`, the run's RMS bound the targets' RMS standard error
    times `k_rms`. Calibrated on 100 skull runs (seeds 76000-76039 and 74000-74059) at their
    97.5 % quantiles, so that a campaign of 60 runs, with its own sampling scatter, still
    finds 95 % of targets and of runs within their bounds (bench/budget_coverage.py prints
    both). `arm_m` [m]: the calibrated arm's error at a target as the budget takes it (None:
    `verify.arm_accuracy_m`), where a cell's campaigns show its arm worse than that."""

    k_target: float = Field(1.40, gt=0.0, le=10.0)
    k_rms: float = Field(1.15, gt=0.0, le=10.0)
    arm_m: float | None = Field(None, gt=0.0, le=0.01)


class VerifySection(Section):
    """The checks before the first touch. The correction (scenarios.offline.verification): the
    laser scans a strip of the object again, and the object's move since the scan is
    measured at each target and held to what the job's goal leaves; a detected move
    re-scans and re-matches once, then refuses. `max_strips`: strips it scans at most to
    make that call; `arm_accuracy_m` [m]: the arm's error at a target after its calibration
    (the job's budget for it); `repeatability_m` [m]: the arm's and the table's pose
    repeatability, one standard deviation per axis (data sheets). The tool at the beam
    (scenarios.offline.tcp_check): `tool_tolerance_m` [m]: how far off a tool may sit (None:
    the job's RMS goal less the error it plans for, the scan's TRE goal and `arm_accuracy_m`
    in quadrature: 0.165 mm for the skull); `tool_reference`: the cell was commissioned, its
    pointed tools read at the beam, and each check differences against those readings (else
    against the tooldata, with the arm's accuracy in its uncertainty). `budget`: the coverage
    factors of the targets' error budget, which says whether the goals are within reach."""

    enabled: bool = True
    max_strips: int = Field(3, ge=1, le=10)
    arm_accuracy_m: float = Field(1.5e-4, ge=0.0, le=0.01)
    repeatability_m: float = Field(2.0e-5, ge=0.0, le=0.01)
    tool_tolerance_m: float | None = Field(None, gt=0.0, le=0.01)
    tool_reference: bool = True
    budget: BudgetCoverage = BudgetCoverage()


class PlanningSettings(Section):
    """All that the stages are told of a job: its `seed` (the match's random starts), the
    cell's layout as the planner knows it (the rack at `rack_xyz` [m]), the object's name in
    the cell, how it is fixed, its nominal placement and the fixture's tolerance, and the
    planning sections. Built from a job's configuration by `JobConfig.planning()`; nothing of
    the real cell's errors, faults or the ranges its placement is drawn from is here."""

    seed: int = Field(0, ge=0)
    rack_xyz: tuple[float, float, float] = (0.0, -0.85, 0.0)
    laser: LaserSection = LaserSection()
    object_name: str = "object"
    fixing: Literal["fixed", "loose"] = "fixed"
    placement: NominalPlacement = NominalPlacement()
    tolerance: FixtureTolerance = FixtureTolerance()
    calibration: Calibration = Calibration()
    localization: LocalizationSection = LocalizationSection()
    operations: OperationsSection = OperationsSection()
    verify: VerifySection = VerifySection()
    #: The job's RMS goal for its targets [m] (None: no goal): what the verification holds a
    #: move of the object to.
    goal_rms_m: float | None = Field(5.0e-4, gt=0.0)
    #: The job's goal for its largest target error [m] (None: no goal).
    goal_max_m: float | None = Field(1.0e-3, gt=0.0)
    #: How far the real object's surface may lie from its model [m], as the job file states
    #: it (two-sided, 95 %): the error budget's floor for the model's term.
    model_tolerance_m: float = Field(5.0e-4, ge=0.0, le=0.01)
