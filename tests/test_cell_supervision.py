"""The controller's supervision on the cell itself: a move into a body is stopped and backed
off, a tool that does not lock is locked again, a stalled table is moved again, a glitching
joint reading is read again. Ground truth: the simulation's contacts and poses (the truth),
and the injector's record of what it did."""

from __future__ import annotations

import numpy as np
import pytest

from cell import SupervisionError
from cell.sim import CellConfig, make_cell
from cell.sim.faults import Fault
from cell.sim.supervision import ContactSensing
from models.robot import TABLE_TOP_POS


def test_a_move_into_a_body_is_stopped_and_backed_off():
    """A box 12 cm under the flange, a straight move 30 cm down: the supervision stops the
    arm on contact (force beyond 40 N), backs it off along its path, and it ends clear of
    the box (no contact), above where it touched."""
    probe, _ = make_cell(CellConfig(seed=1))
    T0 = probe.T_base_tcp()
    p_box = T0[:3, 3] - [0.0, 0.0, 0.12 + 0.03]
    where = tuple(p_box - np.array(TABLE_TOP_POS))
    obstacle = Fault("obstacle", 0.06, None, None, where)
    controller, truth = make_cell(CellConfig(seed=1, faults=(obstacle,)))
    T1 = T0.copy()
    T1[2, 3] -= 0.3
    with pytest.raises(SupervisionError) as stop:
        controller.move_linear(T1, speed_m_s=0.1)
    assert stop.value.code == "collision"
    event = controller.events[-1]
    assert event.code == "collision" and event.action == "stopped"
    force, _ = ContactSensing(truth.simulation, lambda: controller.tool_in_hand).external()
    assert force == 0.0
    z_contact = p_box[2] + 0.03  # the box's top
    z_flange = truth.simulation.site_T(truth.simulation.flange_site)[2, 3]
    assert z_flange > z_contact + 1e-3  # backed off, clear of the top
    assert z_flange < T0[2, 3] - 0.05  # it did go down towards the box first


def test_no_lock_is_locked_again():
    controller, truth = make_cell(CellConfig(seed=1, faults=(Fault("tool_lock_fail", 0.0),)))
    controller.change_tool("laser")
    assert controller.tool_in_hand == "laser"
    assert "tool_lock_fail" in truth.faults.fired
    assert [(e.code, e.action) for e in controller.events] == [("lock_sensor", "retried")]


@pytest.mark.parametrize("readout", ["honest", "lying"])
def test_a_stalled_table(readout: str):
    """Honest readout: the in-position check sees the stall and moves again (the table ends
    within 0.2 mm of the target). A lying readout cannot be seen here: the table stays
    10 mm short while its readout shows the target (the verification after the match
    is what sees it)."""
    controller, truth = make_cell(
        CellConfig(seed=1, faults=(Fault("table_stall", 0.01, None, readout),))
    )
    controller.move_table(0.2)
    assert "table_stall" in truth.faults.fired
    assert abs(controller.table_position() - 0.2) <= 2e-4
    true_off = truth.table_position_m() - truth.table_error_m() - 0.2
    if readout == "honest":
        assert [(e.code, e.action) for e in controller.events] == [("table_in_position", "retried")]
        assert abs(true_off) <= 2e-4
        # The event keeps what it read and the window it held it to: the stall, 10 mm.
        (event,) = controller.events
        assert event.reading == pytest.approx(0.01, abs=5e-4) and event.limit == 2e-4
    else:
        assert controller.events == []
        assert true_off == pytest.approx(-0.01, abs=2e-4)


def test_a_joint_glitch_is_read_again():
    controller, truth = make_cell(CellConfig(seed=1, faults=(Fault("encoder_glitch", 0.05),)))
    readings = np.array([controller.read_joints() for _ in range(80)])
    assert "encoder_glitch" in truth.faults.fired
    assert np.abs(readings - truth.q()).max() < 1e-3  # no reading carried the jump
    assert [(e.code, e.action) for e in controller.events] == [("joint_plausibility", "re-read")]
    (event,) = controller.events  # the jump (0.05 rad) read, against the 1 mrad limit
    assert event.reading == pytest.approx(0.05, abs=1e-3) and event.limit == 1e-3
