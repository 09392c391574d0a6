"""A job on a controller across the network (`twincell run JOB --controller URL`): the stages
drive an ABB IRC5, or `twincell serve` standing in for one in another process, through the
controller client (scenarios.irc5). The job's process holds no truth: where the controller is
the twin, the twin measures each touch of the job (a stop named for the target, as the job's
exported program names its touches) and each program it runs, and writes the measurements to
its $HOME/executions/; the run's report joins them. A real controller has no such folder: the
report then has no true errors.

The user's credentials come from the environment (TWINCELL_RWS_USER, TWINCELL_RWS_PASSWORD)
or a file named by TWINCELL_RWS_CREDENTIALS (one line NAME:PASSWORD), never from the command
line; neither reaches config.yaml or results.json.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from urllib.parse import urlparse

import numpy as np

from cell.robot_arm import Robot
from models.model import ObjectModel
from registration.rigid import transform_points
from scenarios.configuration.job_config import JobConfig
from scenarios.irc5.analog_laser import AnalogLaser
from scenarios.irc5.egm_feedback import EgmFeedback
from scenarios.irc5.line_profiler import ProfileBuffer, ProfileStream
from scenarios.irc5.motion_witness import MotionWitness
from scenarios.irc5.move_modules import MODULE
from scenarios.irc5.remote_controller import ClientSettings, RemoteController
from scenarios.irc5.rws_link import RwsLink
from scenarios.jobs.job_plan import JobPlan
from scenarios.offline.scan_passes import ObjectBox
from scenarios.rapid.rapid_text import rapid_identifier
from scenarios.rapid.writer import PROGRAM_MODULE
from scenarios.realcell.cell_log import CellLog
from scenarios.realcell.setup import JobCell
from scenarios.results.edge import JsonObject
from scenarios.results.evaluations import TargetEvaluation
from scenarios.results.exported_result import ExportedRun, TargetError
from scenarios.scenario_errors import ScenarioError

Progress = Callable[[str], None]
#: Where the twin writes what it measured, on the controller.
EXECUTIONS = "$HOME/executions"
USER_ENV, PASSWORD_ENV, FILE_ENV = (
    "TWINCELL_RWS_USER",
    "TWINCELL_RWS_PASSWORD",
    "TWINCELL_RWS_CREDENTIALS",
)
DEFAULT_USER = ("Default User", "robotics")


@dataclass(frozen=True)
class ControllerAddress:
    """Where the controller is: its Robot Web Services (`url`, http://HOST:PORT), the UDP
    port of this computer its EGM stream comes to, and the line laser's profile stream
    (host, port; None: no line laser)."""

    url: str
    egm_port: int
    profiles: tuple[str, int] | None = None

    @classmethod
    def parse(cls, url: str, egm_port: int | None, profiles: str | None) -> ControllerAddress:
        """From the command line's words; ScenarioError naming what was given."""
        parsed = urlparse(url)
        if parsed.scheme not in ("http", "https") or not parsed.hostname or not parsed.port:
            raise ScenarioError(
                f"--controller {url!r}: give the controller's Robot Web Services as "
                "http://HOST:PORT, e.g. http://192.168.125.1:80"
            )
        if egm_port is None:
            raise ScenarioError(
                "--controller needs --egm-port: the UDP port of this computer the controller's "
                "EGM stream is sent to (its UCdevice's remote port)"
            )
        stream = None
        if profiles is not None:
            host, sep, port = profiles.rpartition(":")
            if not sep or not host or not port.isdigit():
                raise ScenarioError(f"--profiles {profiles!r}: give HOST:PORT")
            stream = (host, int(port))
        return cls(url.rstrip("/"), egm_port, stream)

    def check_laser(self, kind: str) -> None:
        """ScenarioError where a profile stream is given for a point laser (`kind` "point"),
        whose readings come in the EGM stream."""
        if kind == "point" and self.profiles is not None:
            host, port = self.profiles
            raise ScenarioError(
                f"--profiles {host}:{port}: the cell's laser is a point laser (cell.laser.kind: "
                "point), read on the controller's analog input in the EGM stream; give no "
                "--profiles"
            )


def credentials(environ: Mapping[str, str] | None = None) -> tuple[str, str]:
    """The RWS user and password: TWINCELL_RWS_USER and TWINCELL_RWS_PASSWORD, else the file
    TWINCELL_RWS_CREDENTIALS names (NAME:PASSWORD), else the controller's default user."""
    env = os.environ if environ is None else environ
    if PASSWORD_ENV in env:
        return env.get(USER_ENV, DEFAULT_USER[0]), env[PASSWORD_ENV]
    if FILE_ENV in env:
        path = Path(env[FILE_ENV])
        try:
            line = path.read_text(encoding="utf-8").strip().splitlines()[0]
        except (OSError, IndexError) as exc:
            raise ScenarioError(f"{FILE_ENV}={path}: cannot read NAME:PASSWORD ({exc})") from None
        name, sep, password = line.partition(":")
        if not sep or not name:
            raise ScenarioError(f"{FILE_ENV}={path}: its first line is not NAME:PASSWORD")
        return name, password
    return DEFAULT_USER


def client_settings(config: JobConfig) -> ClientSettings:
    """How the client works: its own modules and the program's unloaded from an earlier
    session; the laser's latency from the data sheet where the job gives it (else 0 until
    the calibration identifies it)."""
    latency = config.calibration.latency
    return ClientSettings(
        own_modules=(MODULE, PROGRAM_MODULE),
        laser_latency_s=0.0 if latency == "identify" else float(latency),
    )


def connect(config: JobConfig, robot: Robot, address: ControllerAddress) -> RemoteController:
    """The job's controller across the network, with the cell's data sheets (the arm, the
    rack's place, the laser's rays). A point laser is read on the controller's analog input,
    from the EGM stream; a line laser from its own profile stream (`address.profiles`; one
    given for a point laser is refused before the job plans: ControllerAddress.check_laser)."""
    user, password = credentials()
    sheet = config.cell.laser.data_sheet()
    link = RwsLink(address.url, user, password)
    feedback = EgmFeedback(address.egm_port)
    profiles = None
    if config.cell.laser.kind == "point":
        profiles = ProfileBuffer(AnalogLaser(feedback, sheet))
    elif address.profiles is not None:
        profiles = ProfileBuffer(ProfileStream(*address.profiles))
    try:
        return RemoteController(
            link,
            feedback,
            profiles,
            robot,
            robot.kinematics(),
            config.cell.rack_xyz,
            sheet,
            settings=client_settings(config),
        )
    except BaseException:
        if profiles is not None:
            profiles.close()
        feedback.close()
        link.close()
        raise


def network_job_cell(
    config: JobConfig, plan: JobPlan, address: ControllerAddress, recording: Any | None = None
) -> tuple[JobCell, RemoteController]:
    """The job's cell across the network: its controller (to close after the job), no
    evaluator, the twin's measurements of the touches; with a `recording`, the cell drawn as
    the job knows it, posed by the controller's stream (scenarios.realcell.recording.
    remote_scene)."""
    controller = connect(config, plan.robot, address)
    try:
        touches = TwinTouches(controller, tuple(h.name for h in plan.virtual.burr_holes))
        if recording is not None:
            controller.witness = _witness(config, plan, controller, recording)
        log = CellLog(recording, controller, None)
        box = ObjectBox.of(plan.virtual.mesh.vertices, plan.T_table_nominal)
        cell = JobCell(controller, None, log, plan.T_table_nominal, box, touches)
    except BaseException:
        controller.close()
        raise
    return cell, controller


def _witness(
    config: JobConfig, plan: JobPlan, controller: RemoteController, recording: Any
) -> MotionWitness:
    """The recording's cell for a run across the network: the job's virtual cell, the arm
    drawn with its meshes, the laser's rays from the controller's arm model."""
    from models.robot.visuals import irb2400_visuals
    from scenarios.offline.job_cell import job_virtual_cell
    from scenarios.realcell.recording.remote_scene import RemoteScene

    name = config.object_name
    cell = job_virtual_cell(
        plan.robot, config.cell.rack_xyz, plan.virtual, plan.T_table_nominal,
        config.calibration.enabled, name,
    )  # fmt: skip
    looks = irb2400_visuals() if plan.robot.name == "irb2400" else ()

    def laser_frame(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        T = controller.kinematics.fk(q) @ controller.T_flange_tcp("laser")
        return T[:3, 3].copy(), controller.laser_directions_tcp @ T[:3, :3].T

    recording.log_model(plan.virtual, plan.T_table_nominal)
    return RemoteScene(recording, cell, name, plan.virtual.name, looks, laser_frame)


def touch_robtarget(target: str) -> str:
    """The robtarget name a program touches `target` with (the writer's p<Name>Touch)."""
    return f"{rapid_identifier(target, 'p')}Touch"[:32]


class TwinTouches:
    """The job's touches as the twin across the network measures them: each touch a stop
    named for its target (`record_touch`; a method's prefix, "surface:", is the job's own
    and not in the name), the measurements read back from the controller's EXECUTIONS folder
    and paired with the touches in their order (`targets`); none from a real controller."""

    def __init__(self, controller: RemoteController, target_names: tuple[str, ...]) -> None:
        self._controller = controller
        self._names = set(target_names)
        self._before = set(controller.link.files(EXECUTIONS))
        self._read: dict[str, JsonObject] = {}
        #: The touches recorded, by their full names, in order.
        self._touched: list[str] = []

    def record_touch(self, target: str, tool: str) -> None:
        name = target.rpartition(":")[2]
        if name in self._names:
            self._touched.append(target)
            self._controller.stop_named(touch_robtarget(name))

    def executions(self) -> list[JsonObject]:
        """What the twin measured of this job's programs since it began (execution.json's
        layout), in order."""
        link = self._controller.link
        for name in sorted(set(link.files(EXECUTIONS)) - self._before - set(self._read)):
            self._read[name] = json.loads(link.read_file(f"{EXECUTIONS}/{name}"))
        return [self._read[name] for name in sorted(self._read)]

    def targets(
        self,
        touch_offset_m: float,
        virtual: ObjectModel,
        T_base_object_estimate: np.ndarray,
        prefix: str = "",
    ) -> tuple[TargetEvaluation, ...]:
        """Each target's last measured touch of those named with `prefix`, its registration
        share from the estimate."""
        pending, last = list(self._touched), {}
        for execution in self.executions():
            if not str(execution["program"]).startswith(MODULE):  # not the job's own moves
                continue
            for t in execution["targets"]:  # the first touch of its name not yet paired
                k = next(i for i, f in enumerate(pending) if f.rpartition(":")[2] == t["name"])
                last[pending.pop(k)] = t
        holes = {h.name: h for h in virtual.burr_holes}
        out = []
        for name, t in last.items():
            if not name.startswith(prefix):
                continue
            hole = holes[name.removeprefix(prefix)]
            p = transform_points(
                T_base_object_estimate, (hole.p_entry - touch_offset_m * hole.direction)[None]
            )[0]
            p_true = np.array(t["p_true_base_m"], dtype=float)
            out.append(
                TargetEvaluation(
                    name,
                    float(t["error_m"]),
                    float(t["axis_error_deg"]),
                    float(t["depth_error_m"]),
                    float(np.linalg.norm(p - p_true)),
                    p_true,
                    np.array(t["p_achieved_base_m"], dtype=float),
                )
            )
        return tuple(out)


def run_exported_remote(
    controller: RemoteController,
    touches: TwinTouches,
    folder: Path,
    program_file: str,
    say: Progress,
    compensation: str = "",
) -> ExportedRun:
    """Run the exported module on the controller as it plans and runs it, its tool put back
    first so that the program fetches it itself (as `twincell execute` runs it); the twin's
    measurement of it (none from a real controller: an ExportedRun without targets)."""
    path = folder / program_file
    if path.is_dir():
        return ExportedRun("refused", f"{program_file}: a task of modules is not sent yet")
    text = path.read_text(encoding="utf-8")
    module = _module_name(text, program_file)
    # as the program would run on its own: the controller fetches its tool itself, from home
    previous = controller.absolute_accuracy
    controller.set_absolute_accuracy(None)
    try:
        if controller.tool_in_hand is not None:
            controller.move_joints(controller.q_home)
            controller.return_tool()
        controller.move_joints(controller.q_home)
        controller.run_program(module, text)
    finally:
        controller.set_absolute_accuracy(previous)
    measured = [e for e in touches.executions() if str(e["program"]).startswith(module)]
    if not measured:
        say(f"{program_file} ran on the controller; no measurement of it came (a real cell)")
        return ExportedRun("complete", "no measurement: the controller is not a twin", program_file)
    executed = measured[-1]
    rms, largest = executed["target_error_rms_m"], executed["target_error_max_m"]
    targets = tuple(TargetError(str(t["name"]), float(t["error_m"])) for t in executed["targets"])
    run = ExportedRun(
        "complete",
        "",
        program_file,
        compensation or str(executed["compensation"]),
        None if rms is None else float(rms),
        None if largest is None else float(largest),
        targets,
    )
    say(
        f"{program_file} ({run.compensation}) on the controller: target error rms "
        f"{(run.target_error_rms_m or 0) * 1e3:.3f} mm, max "
        f"{(run.target_error_max_m or 0) * 1e3:.3f} mm (the twin's measurement)"
    )
    return run


def _module_name(text: str, program_file: str) -> str:
    for line in text.splitlines():
        words = line.split()
        if len(words) >= 2 and words[0].upper() == "MODULE":
            return words[1].rstrip("(")
    raise ScenarioError(f"{program_file}: no MODULE line")
