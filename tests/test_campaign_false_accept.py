"""A full trial's row counts a false accept where the match accepted a wrong pose, also when
a later check stopped the run before any target was reached."""

from __future__ import annotations

import json
from pathlib import Path

from scenarios.campaign.full_stage import full_row
from scenarios.results.json_converter import structure
from scenarios.results.run import RunResult

#: The assembly job, seed 30036, as its run wrote results.json: the scan matched the bracket
#: half-turned (the evaluator's truth: 180 deg and 40 mm off), the match was accepted, and the
#: check stage refused the corrected program (it collides) before any motion to the part.
HALF_TURNED = Path(__file__).parent / "data" / "results" / "assembly_seed30036_half_turned.json"


def test_a_wrong_pose_stopped_before_its_targets_is_a_false_accept() -> None:
    data = json.loads(HALF_TURNED.read_text())
    row = full_row(structure(data, RunResult), ())
    assert row["run_status"] == "refused" and row["accepted"] == 1 and row["n_targets"] == 0
    assert row["false_accept"] == 1 and row["good"] == 0


def test_a_right_pose_stopped_before_its_targets_is_no_false_accept() -> None:
    """The same record with the pose's error within 2 mm and 1 deg (the good match's bound)."""
    data = json.loads(HALF_TURNED.read_text())
    data["methods"]["surface"]["rotation_error_deg"] = 0.9
    data["methods"]["surface"]["translation_error_m"] = 1.9e-3
    row = full_row(structure(data, RunResult), ())
    assert row["false_accept"] == 0
    data["methods"]["surface"]["translation_error_m"] = 2.1e-3
    assert full_row(structure(data, RunResult), ())["false_accept"] == 1
