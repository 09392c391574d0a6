"""The changes proposed where the virtual cell refuses a user's program
(scenarios.offline.program_proposal), and where the arm cannot do a job
(scenarios.offline.reach_proposal): the least change that passes, found and said; none
where nothing passes. The cells here are stand-ins whose verdicts the tests state."""

from __future__ import annotations

import numpy as np
import pytest

from scenarios.offline.program_proposal import (
    Findings,
    backed_off,
    propose_changes,
    turned,
)
from scenarios.program.program_types import Operation


def _operation(name: str, p: tuple[float, float, float]) -> Operation:
    T = np.eye(4)
    T[:3, :3] = np.diag([1.0, -1.0, -1.0])  # the tool's z pointing down
    T[:3, 3] = p
    return Operation(name, T, 0.06, None)


def _turn_deg(op: Operation) -> float:
    x = op.T_object_touch[:3, 0]
    return float(np.degrees(np.arctan2(-x[1], x[0])))  # about the downward z


def test_turned_and_backed_off_move_the_touch_as_said() -> None:
    op = _operation("a", (0.1, 0.0, 0.05))
    t = turned(op, 90.0)
    assert np.allclose(t.T_object_touch[:3, 3], op.T_object_touch[:3, 3])
    assert np.allclose(t.T_object_touch[:3, 2], op.T_object_touch[:3, 2])  # same axis
    assert _turn_deg(t) == pytest.approx(90.0)
    assert np.allclose(t.T_object_approach[:3, 3], op.T_object_approach[:3, 3], atol=1e-12)
    b = backed_off(op, 0.003)
    assert np.allclose(b.T_object_touch[:3, 3], [0.1, 0.0, 0.053])  # up: back along z
    assert np.allclose(b.T_object_approach, op.T_object_approach)  # the approach kept
    assert b.approach_m == pytest.approx(0.057)


def test_a_deep_touch_is_moved_back_by_its_depth_and_more() -> None:
    """The stand-in refuses a touch lower than 52 mm; it went 2.0 mm in (as the check says):
    it is moved back 3.0 mm (2 + 1, the first back-off that passes); the other is kept."""
    ops = (_operation("deep", (0.1, 0.0, 0.05)), _operation("fine", (0.0, 0.1, 0.06)))

    def refused(trial: tuple[Operation, ...]) -> Findings:
        return {
            op.name: ["approach -> touch: tool_screwer touches object (2.0 mm deep) at 100 %"]
            for op in trial
            if op.T_object_touch[2, 3] < 0.052
        }

    proposal = propose_changes(ops, refused)
    assert proposal is not None and list(proposal.changes) == ["deep"]
    assert proposal.changes["deep"].said == "move it back 3.0 mm along the tool's axis"
    assert proposal.operations[0].T_object_touch[2, 3] == pytest.approx(0.053)
    assert proposal.operations[1] is ops[1]
    assert proposal.text().startswith("deep: move it back 3.0 mm along the tool's axis (touch [[")


def test_a_blocked_touch_is_turned_the_least_that_passes() -> None:
    """The stand-in refuses a touch turned less than 50 degrees either way: 60 is proposed
    (30, -30 refused first)."""
    ops = (_operation("side", (0.1, 0.0, 0.05)),)
    seen: list[float] = []

    def refused(trial: tuple[Operation, ...]) -> Findings:
        turn = _turn_deg(trial[0])
        seen.append(round(turn))
        return {} if abs(turn) >= 50.0 else {"side": ["the arm is near a singularity"]}

    proposal = propose_changes(ops, refused)
    assert proposal is not None
    assert proposal.changes["side"].said == "turn it +60 deg about the tool's axis"
    assert seen == [0, 30, -30, 60]


def test_no_proposal_where_no_change_passes() -> None:
    ops = (_operation("a", (0.1, 0.0, 0.05)), _operation("b", (0.0, 0.1, 0.05)))
    assert propose_changes(ops, lambda trial: {"b": ["out of reach"]}) is None
    assert propose_changes(ops, lambda trial: {}) is None  # nothing refused: nothing to change


def test_authoring_proposes_an_order_a_table_position_or_a_turn_that_passes() -> None:
    """The stand-in virtual cell passes only what the test says; the search proposes exactly
    that, in the documented order (orders, then table positions, then turns), and None where
    nothing passes."""
    from pathlib import Path
    from types import SimpleNamespace

    from scenarios.configuration.config_files import load_config
    from scenarios.jobs.authoring_proposal import checked_change

    example = Path(__file__).resolve().parent.parent / "examples" / "my_cell"
    config = load_config(example / "job.yaml", cell=example / "cell.yaml")  # yaw 120 deg
    touches = [SimpleNamespace(name=n) for n in ("a", "b", "c")]

    def names(order) -> str:
        return "".join(t.name for t in order)

    def only(order: str = "", table_m: float | None = None, yaw: float | None = None):
        def attempt(job, table, tried) -> bool:
            return (
                (not order or names(tried) == order)
                and (table_m is None or table == table_m)
                and (yaw is None or job.cell.object.placement.yaw_deg == yaw)
            )

        return attempt

    said: list[str] = []
    assert checked_change(config, 0.0, touches, only(order="cab"), said.append) == (
        "the touches in the order c, a, b"
    )
    assert said == ["trying 5 other orders of the touches, then the table's positions"]
    assert checked_change(config, 0.0, touches, only("abc", table_m=0.2)) == "--table 200"
    assert checked_change(config, 0.0, touches, only("abc", 0.0, yaw=-60.0)) == (
        "--set cell.object.placement.yaw_deg=-60 (the part turned +180 deg on the table)"
    )
    assert checked_change(config, 0.0, touches, only("bca", 0.0, yaw=150.0)) == (
        "--set cell.object.placement.yaw_deg=150 (the part turned +30 deg on the table), "
        "the touches in the order b, c, a"
    )
    assert checked_change(config, 0.0, touches, lambda job, table, tried: False) is None
