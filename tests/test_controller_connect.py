"""The robot side a user loads on a real IRC5 (the helper module TcHelper.sys, the signals of
EIO.cfg, the RobotWare options) and `twincell connect`, which checks a controller for them:
against the twin served in process as commissioned (everything there), then with what a
controller can lack taken away one by one (the helper module, the motors, automatic mode,
the credentials); each must be named, with what to change. Ground truth: what the test took
away, and the signals the client itself reads and writes."""

from __future__ import annotations

import re
import socket
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from abb_robot_client.rws import RWS
from bench_support.served_twin import free_port

from cell.controller import SETTLE_S
from cell.irb2400_arm import irb2400
from scenarios.cli import main
from scenarios.cli.connect_command import render
from scenarios.irc5 import controller_check
from scenarios.irc5.controller_check import check_controller
from scenarios.irc5.egm_feedback import beam_of, feedback_of
from scenarios.irc5.helper_module import (
    HELPER,
    HELPER_FILE,
    UDP_DEVICE,
    helper_text,
    helper_version,
    needed_signals,
)
from scenarios.irc5.link_errors import ControllerRefusalError
from scenarios.irc5.move_modules import Tool, joint_move
from scenarios.irc5.rws_link import RwsLink
from scenarios.jobs.serve import Serving, serve_job
from scenarios.rapid.planner import plan_execution
from scenarios.rapid.reader import read_module
from scenarios.rapid.task import RapidTask, read_task
from scenarios.twin.egm_proto import EgmRobot
from scenarios.twin.server import ServeOptions
from scenarios.twin.signals import BY_NAME

REMOTE = Path(__file__).parents[1] / "scenarios" / "irc5" / "remote_controller.py"


#: The UDP port the served twin streams EGM to (its UDP device's remote port).
EGM_PORT = free_port(socket.SOCK_DGRAM)


@pytest.fixture
def served(tmp_path: Path) -> Iterator[Serving]:
    """The skull job's real cell served in process on a free port, as commissioned, its EGM
    streaming to this computer's EGM_PORT."""
    serving = serve_job("skull", ServeOptions(port=0, egm_port=EGM_PORT), out=tmp_path)
    yield serving
    serving.close()


def _check(
    serving: Serving, password: str = "robotics", egm_port: int | None = EGM_PORT
) -> controller_check.ControllerCheck:
    link = RwsLink(serving.url, "Default User", password, timeout_s=5.0)
    try:
        return check_controller(link, egm_port)
    finally:
        link.close()


def _missing(report: controller_check.ControllerCheck) -> dict[str, str]:
    return {f.what: f.change for f in report.missing}


def test_the_shipped_signals_are_those_the_client_uses_and_the_twin_serves() -> None:
    needs = {n.name: n.type for n in needed_signals()}
    client_text = REMOTE.read_text(encoding="utf-8")
    used = set(re.findall(r'"((?:do|di|ai|ao)[A-Z]\w+)"', client_text))
    # every signal the client reads or writes is configured, and so is the beam TcHelper streams
    assert used <= set(needs), used - set(needs)
    assert "diTcBeam" in needs and "diTcBeam" in helper_text()
    for name, kind in needs.items():
        assert BY_NAME[name.casefold()].type == kind, name


def test_the_helper_module_reads_and_the_twin_runs_a_move_module_with_it_unchanged() -> None:
    helper = read_module(HELPER_FILE)
    assert read_task([HELPER_FILE]).warnings == () and helper.name == HELPER
    assert helper_version() == "2"
    robot = irb2400()
    kinematics = robot.kinematics()
    q_start = np.array([0.0, 0.1, 0.1, 0.0, 0.5, 0.0])
    q_to = q_start + np.array([0.2, 0.0, 0.0, 0.0, 0.0, 0.1])
    move = read_module(joint_move(q_to, None, (100.0, 30.0), 0.0, Tool(None, np.eye(4))), "m")
    plan = plan_execution(RapidTask((move, helper)), kinematics, {}, q_start, robot.joint_speed)
    assert len(plan.moves) == 1
    # the module writes the joints in degrees to six significant digits: within 1e-5 rad
    np.testing.assert_allclose(plan.moves[0].q, q_to, atol=1e-5)
    # the stream's set-up runs on the controller; the twin follows it as steps it skips
    skipped = " ".join(plan.skipped)
    for instruction in ("EGMSetupUC", "CONNECT", "ISignalDI", "EGMActJoint"):
        assert instruction in skipped, instruction


@pytest.mark.parametrize(
    ("settle_s", "zone", "stop_time_s"),
    [(0.0, "z0", None), (SETTLE_S, "fine", None), (0.2, "fine \\Inpos:=tcStop", 0.2)],
)
def test_a_move_module_stands_the_time_the_client_asks(
    settle_s: float, zone: str, stop_time_s: float | None
) -> None:
    """A move that settles the controller's own time is a `fine` point; one that settles
    another time names a stoppointdata of type stoptime, which the twin's planner reads back
    as the time the arm stands still (the executor settles that long); none is fly-by."""
    robot = irb2400()
    q_start = np.array([0.0, 0.1, 0.1, 0.0, 0.5, 0.0])
    text = joint_move(q_start + 0.1, None, (100.0, 30.0), settle_s, Tool(None, np.eye(4)))
    assert f", {zone}, tool0;" in text
    move = read_module(text, "m")
    helper = read_module(HELPER_FILE)
    plan = plan_execution(
        RapidTask((move, helper)), robot.kinematics(), {}, q_start, robot.joint_speed
    )
    (planned,) = plan.moves
    assert planned.stop == (settle_s > 0.0)
    assert planned.stop_time_s == stop_time_s
    assert planned.supervised


def test_a_move_module_outside_the_supervision_plans_its_move_unsupervised() -> None:
    """A move the client runs with the supervision off has MotionSup \\Off before it; the
    twin's planner reads the move as unsupervised (its executor runs it so)."""
    robot = irb2400()
    q_start = np.array([0.0, 0.1, 0.1, 0.0, 0.5, 0.0])
    text = joint_move(q_start + 0.1, None, (100.0, 30.0), SETTLE_S, Tool(None, np.eye(4)), False)
    assert "    MotionSup \\Off;\n    MoveAbsJ" in text
    plan = plan_execution(
        RapidTask((read_module(text, "m"), read_module(HELPER_FILE))),
        robot.kinematics(), {}, q_start, robot.joint_speed,
    )  # fmt: skip
    assert [m.supervised for m in plan.moves] == [False]


def test_the_beam_arrives_in_the_first_dnum_of_the_stream() -> None:
    """tcToSensor{1} is the first dnum; a stream without RAPIDfromRobot (an EGM that sends
    no DataToSensor values) is refused when the beam is read, not read as a beam unbroken."""

    class State:
        joint_angles = np.zeros(6)
        external_axes = None
        rapid_running = False
        motors_on = True

        def __init__(self, dnum: list[float]) -> None:
            self.robot_message = EgmRobot()
            self.robot_message.RAPIDfromRobot.dnum.extend(dnum)

    assert beam_of(feedback_of(State([1.0]), 0.0)) is True
    assert beam_of(feedback_of(State([0.0]), 0.0)) is False
    with pytest.raises(ControllerRefusalError, match=r"no RAPIDfromRobot.*update the controller"):
        beam_of(feedback_of(State([]), 0.0))


def test_connect_finds_all_on_the_commissioned_twin(
    served: Serving, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    report = _check(served)
    assert report.ok, report.missing
    whats = [f.what for f in report.findings]
    for what in ("RobotWare", "option 616-1", "option 689-1", f"module {HELPER}", "motors"):
        assert what in whats
    assert sum(w.startswith("signal ") for w in whats) == len(needed_signals())
    out = tmp_path / "connect.json"
    assert main(["connect", served.url, "--egm-port", str(EGM_PORT), "--json", str(out)]) == 0
    assert f"all {len(whats)} as the jobs need them" in capsys.readouterr().out
    assert len(whats) == 23  # 3 options, 12 signals, the UDP device
    assert f"UDP device {UDP_DEVICE}" in whats
    assert '"ok": true' in out.read_text()


def test_connect_names_what_was_taken_away(served: Serving) -> None:
    rws = RWS(served.url, "Default User", "robotics")
    rws._do_post("rw/rapid/tasks/T_ROB1?action=unloadmod", {"module": HELPER})
    rws.set_controller_state("motoroff")
    missing = _missing(_check(served))
    assert set(missing) == {f"module {HELPER}", "motors"}
    assert str(HELPER_FILE) in missing[f"module {HELPER}"]
    assert "motors on" in missing["motors"]
    assert main(["connect", served.url]) == 1


def test_connect_names_a_udp_device_that_streams_elsewhere_or_is_missing(
    served: Serving, tmp_path: Path
) -> None:
    """The UDP device EGM streams to is read from the system configuration: a port other
    than the job's is named with the port to set; a controller without the device (the twin
    served without EGM) is told to add it, with this computer's address."""
    elsewhere = _missing(_check(served, egm_port=EGM_PORT + 1))
    assert set(elsewhere) == {f"UDP device {UDP_DEVICE}"}
    assert f"remote port to {EGM_PORT + 1}" in elsewhere[f"UDP device {UDP_DEVICE}"]
    bare = serve_job("skull", ServeOptions(port=0), out=tmp_path / "bare")
    try:
        missing = _missing(_check(bare))
    finally:
        bare.close()
    assert set(missing) == {f"UDP device {UDP_DEVICE}"}
    change = missing[f"UDP device {UDP_DEVICE}"]
    assert f"a UDPUC named {UDP_DEVICE}, remote address 127.0.0.1" in change
    assert f"remote port {EGM_PORT}" in change


def test_the_helper_module_streams_to_the_device_the_twin_serves() -> None:
    assert f'"{UDP_DEVICE}"' in helper_text()
    assert re.search(rf'EGMSetupUC ROB_1, egmTc, "default", "{UDP_DEVICE}"', helper_text())
    assert ServeOptions().egm_device == UDP_DEVICE


def test_connect_names_manual_mode_and_refused_credentials(tmp_path: Path) -> None:
    serving = serve_job("skull", ServeOptions(port=0, opmode="MANR"), out=tmp_path)
    try:
        missing = _missing(_check(serving, egm_port=None))
        assert set(missing) == {"operating mode", "mastership", f"UDP device {UDP_DEVICE}"}
        assert "automatic" in missing["operating mode"]
        refused = _check(serving, password="wrong")
    finally:
        serving.close()
    assert [f.what for f in refused.findings] == ["credentials"]
    assert "TWINCELL_RWS_PASSWORD" in refused.findings[0].change


def test_a_device_s_signals_missing_leave_the_other_jobs_ready() -> None:
    """A controller without the gripper's signals and option serves the skull job: they are
    named, with the jobs that need them, and the controller is ready for the others."""
    lacking = controller_check._option("613-1", "Collision Detection", "x", ["616-1 PC"])
    findings = (
        controller_check.Finding("answers", True, "twin"),
        controller_check._for_device(lacking, "gripper"),
        controller_check._for_device(
            controller_check.Finding("signal diGripperReady", False, "no such signal"), "gripper"
        ),
    )
    report = controller_check.ControllerCheck("http://cell", findings)
    assert report.ok and report.missing == () and len(report.missing_for_some) == 2
    text = render(report)
    assert "(needed by jobs that grip only)" in text
    assert "2 that only some jobs need missing" in text
    bare = controller_check.ControllerCheck(
        "http://cell", (controller_check.Finding("motors", False, "motoroff"), *findings[1:])
    )
    assert not bare.ok and [f.what for f in bare.missing] == ["motors"]


def test_robotware_7_and_missing_options_are_named() -> None:
    seven = controller_check._robotware({"rwversionname": "7.10.0"})
    assert not seven.ok and "RWS 2.0" in seven.change
    assert controller_check._robotware({"rwversion": "6.08.0134"}).ok
    lacking = controller_check._option("689-1", "Externally Guided Motion", "x", ["616-1 PC"])
    assert not lacking.ok and "689-1 Externally Guided Motion" in lacking.change
