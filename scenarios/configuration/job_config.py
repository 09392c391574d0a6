"""A job's configuration as one validated object (`JobConfig`, and the seed paper's
`PaperConfig`): its sections, and what the stages are told of it (`JobConfig.planning`)."""

from __future__ import annotations

from typing import Literal

from pydantic import (
    Field,
)

from scenarios.configuration.cell_sections import (
    CellSection,
    ModelSection,
)
from scenarios.configuration.fault_sections import (
    FaultsSection,
)
from scenarios.configuration.register_trial_sections import (
    RegisterTrialSection,
)
from scenarios.configuration.shift_section import ShiftSection
from scenarios.offline.settings import (
    Calibration,
    LocalizationSection,
    NominalPlacement,
    OperationsSection,
    PlanningSettings,
    Section,
    VerifySection,
)


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


class Checks(Section):
    """The goals a run is held to: RMS and largest error of the achieved tool tips against
    the true targets [m] (None: no goal). A match that is not accepted stops the run before
    any motion towards the object, whatever the goals."""

    target_error_rms_m: float | None = Field(0.5e-3, gt=0.0)
    target_error_max_m: float | None = Field(1.0e-3, gt=0.0)


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
    shift: ShiftSection = ShiftSection()
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
            laser=self.cell.laser,
            object_name=self.object_name,
            fixing=obj.fixing,
            placement=NominalPlacement(**p.model_dump(include=set(NominalPlacement.model_fields))),
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


#: The kinds of configuration, by their `kind` key.
KINDS: dict[str, type[JobConfig] | type[PaperConfig]] = {"cell": JobConfig, "paper": PaperConfig}
