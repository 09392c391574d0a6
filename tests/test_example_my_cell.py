"""The worked example examples/my_cell: a user's cell, mesh, RAPID module and end-to-end tests
with the pytest plugin. Its files agree with each other (fast); its own tests pass, run as a
user runs them, in their folder (slow)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from cell import nominal_T_base_table
from models.registry import load_model
from scenarios.configuration.config_files import load_config
from scenarios.configuration.job_config import JobConfig
from scenarios.offline.nominal_placement import nominal_pose
from scenarios.offline.operations import check_program_frame, read_user_program

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "my_cell"


def test_the_example_s_program_is_written_for_its_virtual_cell() -> None:
    """The job and cell load and validate; the module's work object lies on the phantom's
    nominal pose (within the check's 2 mm and 1 degree) and its four touches are the moves'."""
    config = load_config(EXAMPLE / "job.yaml", cell=EXAMPLE / "cell.yaml")
    assert isinstance(config, JobConfig)
    assert config.operations.program == str(EXAMPLE / "burr_holes.mod")
    phantom, warnings = load_model(config.cell.object.model, units=config.cell.object.units)
    assert warnings == () and len(phantom.mesh.faces) == 24000
    user = read_user_program(config.operations)
    T_table_object = nominal_pose(config.cell.object.placement, phantom.mesh.vertices)
    check_program_frame(user, nominal_T_base_table(user.table_position_m) @ T_table_object)
    assert [op.name for op in user.operations] == [f"pTouch{k}" for k in range(4)]


@pytest.mark.slow
def test_the_example_s_tests_pass_as_a_user_runs_them(tmp_path: Path) -> None:
    """`pytest` in the example's folder, over one seed instead of its ten (CI's time): the
    goals met, the bumped fixture detected, the edited touch caught, the served cell answering."""
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-n", "0",
         "--twincell-seeds", "1", "--basetemp", str(tmp_path / "base")],
        cwd=EXAMPLE, capture_output=True, text=True, timeout=900,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout[-4000:] + done.stderr[-2000:]
    assert "4 passed" in done.stdout, done.stdout[-2000:]
