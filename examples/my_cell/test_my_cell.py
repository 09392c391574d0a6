"""End-to-end tests of my cell: `pytest -n 2` in this folder (twincell's plugin does the rest)."""

from pathlib import Path

import pytest
from abb_robot_client.rws import RWS

from scenarios.testing import assert_detected, assert_goals

JOB, CELL = "job.yaml", "cell.yaml"


@pytest.mark.twincell_seeds(10)
def test_my_program_meets_the_goals(run_job, twincell_seed):
    assert_goals(run_job(JOB, seed=twincell_seed, cell=CELL))


def test_a_bumped_fixture_is_caught(run_job):
    bumped = run_job(JOB, seed=0, cell=CELL, overrides={"faults.object_bump": 0.002})
    assert_detected(bumped, "object_bump")


def test_a_touch_edited_into_the_phantom_is_caught(run_job, tmp_path):
    edited = tmp_path / "edited.mod"  # pParietal_right 3 mm deeper: a typo in the module
    program = (Path(__file__).parent / "burr_holes.mod").read_text()
    edited.write_text(program.replace("69.3871]", "66.3871]"))
    with pytest.raises(AssertionError, match="pParietal_right: approach -> touch"):
        assert_goals(run_job(JOB, seed=0, cell=CELL, program=edited))


def test_my_controller_answers(served_twin):
    twin = served_twin(JOB, seed=0, cell=CELL)  # my cell, served as its IRC5 would answer
    assert RWS(twin.url).get_controller_state() == "motoron"
    assert list(twin.config.cell.robot.home_deg) == [0, 0, 0, 0, 90, 0]  # cell.yaml's home
