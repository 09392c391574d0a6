"""The export: the corrected program written for the user's controller (program.mod for an
ABB arm, the corrected targets and the tool's data for any arm), filtered for the calibrated
arm if the job asks."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cell import Controller, Kinematics
from cell.robot_arm import Robot
from models.atomic import write_bytes, write_text
from scenarios.offline.calibration import CalibrationResult
from scenarios.offline.operations import UserProgram
from scenarios.outputs import toolchain_exports as exports
from scenarios.outputs.run_files import write_program
from scenarios.outputs.user_program_export import filter_refusal, written_back
from scenarios.program.program_types import OfflineProgram
from scenarios.rapid.writer import Filter
from scenarios.stages.context import StageContext
from scenarios.stages.stage import Outcome

Progress = Callable[[str], None]


@dataclass(frozen=True, eq=False)
class Exported(Outcome):
    """The program the job hands out: the first method's corrected program (None: none,
    the pose was refused), the file written for the controller (None: the arm runs no
    RAPID; the targets are in targets.csv and targets.json) and the compensation it was
    written with ("filtered" or "nominal"; "" with no program)."""

    program: OfflineProgram | None = None
    program_file: str | None = None
    compensation: str = ""


@dataclass(frozen=True)
class Export:
    """The stage "export", with the exported program's `compensation` ("filtered" for the
    calibrated arm, or "nominal")."""

    compensation: str = "filtered"
    name: str = "export"
    title: str = "the corrected program for the controller"

    def due(self, ctx: StageContext) -> bool:
        return True

    def run(self, ctx: StageContext) -> Exported:
        state, controller, say = ctx.state, ctx.controller, ctx.hooks.say
        primary = state.primary(ctx.settings.localization.methods)
        program = state.programs.operations.get(primary.method)
        if program is None:
            return Exported()
        calibration = state.calibration
        filtered = program_filter(
            self.compensation, calibration, ctx.user, controller, program.tool, say
        )
        program_file = export_program(
            ctx.folder,
            program,
            ctx.T_table_nominal,
            ctx.user,
            controller.robot,
            say,
            controller.nominal_kinematics,
            filtered,
            None if calibration is None else calibration.kinematics,
        )
        return Exported(program, program_file, "nominal" if filtered is None else "filtered")


def program_filter(
    compensation: str,
    calibration: CalibrationResult | None,
    user: UserProgram | None,
    controller: Controller,
    tool: str,
    say: Progress,
) -> Filter | None:
    """The exported program's filter for the calibrated arm (compensation "filtered"), or
    None: the nominal poses, as asked or, said why, when there is no calibrated arm or the
    user's own module cannot be filtered (scenarios.outputs.user_program_export). A user's
    module is written back with its oframe corrected either way; the log says which
    compensation it gets."""
    refusal = None
    if compensation == "filtered":
        if calibration is None:
            refusal = "filtering needs the calibrated arm"
        elif user is not None:
            refusal = filter_refusal(user)
    if compensation != "filtered" or refusal is not None:
        if refusal is not None:
            kept = "; your own module keeps its robtargets" if user is not None else ""
            say(f"program: compensation nominal: {refusal}{kept}")
        elif user is not None:
            say("program: compensation nominal: your own module keeps its robtargets")
        return None
    assert calibration is not None
    return Filter(
        calibration.kinematics,
        controller.nominal_kinematics,
        controller.T_base_slot(tool),
        controller.q_home,
    )


#: The folder a user's task of several modules is written back to, in the run folder.
TASK_FOLDER = "program"


def export_program(
    folder: Path,
    program: OfflineProgram,
    T_table_nominal: np.ndarray,
    user: UserProgram | None,
    robot: Robot,
    say: Progress,
    nominal: Kinematics | None = None,
    filtered: Filter | None = None,
    calibrated: Kinematics | None = None,
) -> str | None:
    """The corrected program for the user's controller: the corrected targets as CSV and
    JSON (in the arm's own base frame) and the tool's data, and for an ABB arm program.mod
    (RAPID: the user's own module with its work object's oframe corrected, or one written
    here, filtered for the calibrated arm if `filtered`, its configuration data from the
    `nominal` arm; the targets' link angles from the `calibrated` arm). Returns the
    program's file name, or None for an arm that does not run RAPID."""
    exports.write_targets(folder, program, robot.T_world_base, calibrated)
    exports.write_tooldata(folder, program.tool)
    if not robot.rapid:
        say(
            f"program: no RAPID module for the {robot.name} ({robot.vendor or 'vendor unknown'}"
            "; RAPID is for ABB arms): the corrected targets are in targets.csv and "
            "targets.json"
        )
        return None
    if user is None:
        write_program(folder / "program.mod", program, T_table_nominal, nominal, filtered)
        return "program.mod"
    back = written_back(user, program, filtered, nominal)
    if filtered is not None:
        say(
            f"program: compensation filtered: your module's touch robtargets "
            f"({', '.join(back.targets)}) and tooldata {', '.join(back.tools) or 'none'} "
            "filtered for the calibrated arm, its oframe corrected"
        )
    if user.task is None or (len(user.task.modules) == 1 and not user.task.opaque):
        write_text(folder / "program.mod", back.texts[0][1])
        return "program.mod"
    # A task: its modules in a folder, each as written back (those that declare none of
    # the data written back as they were), its encrypted modules as they were.
    for module, text in back.texts:
        assert module.path is not None  # a task's modules are read from files
        write_text(folder / TASK_FOLDER / module.path.name, text)
    for path in user.task.opaque:
        write_bytes(folder / TASK_FOLDER / path.name, path.read_bytes())
    return TASK_FOLDER
