"""The cell's devices across the network (scenarios.irc5.remote_devices against the twin's
scenarios.twin.cell_io): the gripper, the screwer's spindle and the IR sensor worked by the
client over the controller's I/O, each measured against the served cell's truth (its
simulation's joints, the table's true height under the sensor), and the motion supervision
switched off for the moves in between.

The twin is the assembly job's real cell, served in this process (its truth at hand for the
measurement only) at 50 times the wall clock; the client reaches it over RWS and EGM as it
would a controller."""

from __future__ import annotations

import socket
from collections.abc import Iterator

import numpy as np
import pytest
from bench_support.served_twin import free_port

from cell import LaserConfig, ToolChangerError
from cell.irb2400_arm import irb2400
from cell.sim.truth import CellTruth
from models.robot import RACK_POS
from scenarios.irc5.egm_feedback import EgmFeedback
from scenarios.irc5.remote_controller import RemoteController
from scenarios.irc5.rws_link import RwsLink
from scenarios.jobs.serve import Serving, serve_job
from scenarios.program.tool_change import change_tool_safely
from scenarios.twin.server import ServeOptions

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def served(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Serving, RemoteController]]:
    port = free_port(socket.SOCK_DGRAM)
    serving = serve_job(
        "assembly", ServeOptions(port=0, egm_port=port), speed=50.0,
        out=tmp_path_factory.mktemp("serve"),
    )  # fmt: skip
    robot = irb2400()
    try:
        client = RemoteController(
            RwsLink(serving.url, "Default User", "robotics"), EgmFeedback(port), None, robot,
            robot.kinematics(), RACK_POS, LaserConfig(),
        )  # fmt: skip
    except BaseException:
        serving.close()
        raise
    yield serving, client
    client.close()
    serving.close()


def _truth(serving: Serving) -> CellTruth:
    evaluator = serving.cell.evaluator
    assert evaluator is not None
    return evaluator._truth


def test_the_gripper_s_fingers_go_where_the_client_asks(
    served: tuple[Serving, RemoteController],
) -> None:
    """aoGripperOpening moves both fingers to the opening asked, within 0.5 mm of it in the
    simulation (no part between them: they are in the air above the rack)."""
    serving, client = served
    change_tool_safely(client, "gripper")
    sim = _truth(serving).simulation
    for opening_m in (0.012, 0.03):
        client.set_gripper(opening_m)
        assert client.link.digital("diGripperReady") == 1
        fingers = sim.data.qpos[sim.finger_qadr]
        np.testing.assert_allclose(fingers, opening_m, atol=5e-4)
    with client.supervision_off():  # the moves' modules run with MotionSup \Off
        client.move_joints(client.q_home)
        assert not client.devices.supervised
    assert client.devices.supervised


def test_the_screwer_turns_its_program_s_time_and_speed(
    served: tuple[Serving, RemoteController],
) -> None:
    """The tightening program's start runs the spindle for its time at its speed: the
    controller's clock advances that long, and the spindle's joint turns speed x time within
    15 % (its drive's spin-up and stop)."""
    serving, client = served
    change_tool_safely(client, "screwer")
    sim = _truth(serving).simulation
    joint = int(sim.model.actuator_trnid[sim.spindle_act, 0])
    adr = int(sim.model.jnt_qposadr[joint])
    angle0, t0 = float(sim.data.qpos[adr]), client.time_s
    client.spin_screwer(20.0, 0.5)
    assert client.link.digital("diSpindleDone") == 0  # the start reset, the handshake ends
    assert client.time_s - t0 >= 0.5
    turned = abs(float(sim.data.qpos[adr]) - angle0)
    assert turned == pytest.approx(10.0, rel=0.15)


def test_the_ir_sensor_reads_the_table_under_it(served: tuple[Serving, RemoteController]) -> None:
    """aiIrRange is the IR sensor's distance: above the bare table, the true height of its
    TCP over the table's top, to its noise (0.2 mm, 4 sigma); beyond its range, None."""
    serving, client = served
    change_tool_safely(client, "ir")
    truth = _truth(serving)
    T_base_table = truth.T_base_table()
    T = np.eye(4)
    T[:3, :3] = T_base_table[:3, :3] @ np.diag([1.0, -1.0, -1.0])  # pointing down
    for height in (0.06, 0.3):
        # over the table's top (its frame's z = 0), 0.15 m off the part at its centre
        T[:3, 3] = (T_base_table @ np.array([-0.15, 0.15, height, 1.0]))[:3]
        client.move_tcp(T)
        p_table = np.linalg.solve(truth.T_base_table(), truth.T_base_tcp("ir")[:, 3])
        reading = client.read_ir()
        if height > 0.15:  # beyond the sensor's range
            assert reading is None
        else:
            assert reading is not None
            assert reading == pytest.approx(float(p_table[2]), abs=8e-4)


def test_a_device_needs_its_tool_in_hand(served: tuple[Serving, RemoteController]) -> None:
    _, client = served
    if client.tool_in_hand == "gripper":
        change_tool_safely(client, "screwer")
    with pytest.raises(ToolChangerError, match="'gripper' tool is not in hand"):
        client.set_gripper(0.01)


def test_no_device_left_a_trace_in_the_event_log(served: tuple[Serving, RemoteController]) -> None:
    """None of the devices' commands failed on the controller."""
    _, client = served
    assert not [e for e in client.link.events() if e.code == 89005], client.link.events()
