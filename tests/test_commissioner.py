"""A cell's commissioning record given to a job (`twincell run --commissioning FILE`): read
back as it was written, refused with what to change when it is of another cell, lacks the
job's tool, or is not a record."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from scenarios.jobs.commissioner import read_commissioning
from scenarios.results.beam import BeamCrossing, BeamReading, Commissioning
from scenarios.results.json_converter import unstructure
from scenarios.scenario_errors import ScenarioError

_Q = (0.1, -0.2, 0.3, 0.0, 0.5, -0.6)
RECORD = Commissioning(
    "irb2400, seed 11",
    (
        BeamReading(
            "screwer", (0.0, 90.0), (BeamCrossing(0.0, _Q, _Q), BeamCrossing(90.0, _Q, _Q))
        ),
        BeamReading("screwer", (0.0, 90.0), (BeamCrossing(0.0, _Q, _Q),)),  # one turn missed
    ),
)


@pytest.fixture
def record_file(tmp_path: Path) -> Path:
    path = tmp_path / "commissioning.json"
    path.write_text(json.dumps(unstructure(RECORD)))
    return path


def test_a_record_reads_back_as_it_was_written(record_file: Path) -> None:
    got = read_commissioning(record_file, "irb2400, seed 11", "screwer")
    assert got == RECORD
    assert len(got.readings("screwer")) == 1  # the complete one


def test_a_record_of_another_cell_is_refused_naming_both(record_file: Path) -> None:
    with pytest.raises(ScenarioError, match=r"'irb2400, seed 11'.*'irb2400, seed 3'"):
        read_commissioning(record_file, "irb2400, seed 3", "screwer")


def test_a_record_without_the_job_s_tool_is_refused_naming_what_it_has(
    record_file: Path,
) -> None:
    with pytest.raises(ScenarioError, match=r"no complete reading of the gripper.*screwer"):
        read_commissioning(record_file, "irb2400, seed 11", "gripper")


def test_a_file_that_is_no_record_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "results.json"
    path.write_text(json.dumps({"status": "complete"}))
    with pytest.raises(ScenarioError, match="not a commissioning record"):
        read_commissioning(path, "irb2400, seed 11", "screwer")
    path.write_text("{not json")
    with pytest.raises(ScenarioError, match="not a commissioning record"):
        read_commissioning(path, "irb2400, seed 11", "screwer")
