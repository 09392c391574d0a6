"""What the stages are told of a job (JobConfig.planning()) holds nothing of the real cell:
a sweep of the truth (its noise, its faults, the ranges its placement is drawn from, the
model error) leaves the planning settings, and so every planned clearance, unchanged; the
fixture's tolerance, the planner's own prior, moves them."""

from __future__ import annotations

import dataclasses

import pytest
from pydantic import BaseModel

from scenarios.configuration.config_files import load_config
from scenarios.offline.job_cell import placement_uncertainty_m
from scenarios.offline.settings import PlanningSettings
from scenarios.stages.context import StageContext
from scenarios.stages.state import JobState

TRUTH_SWEEP = {
    "cell.object.placement.range_xy_m": 0.12,
    "cell.object.placement.range_yaw_deg": 90.0,
    "cell.object.placement.range_tilt_deg": 20.0,
    "cell.noise.laser_sigma_m": 5.0e-4,
    "cell.noise.arm_length_sigma_m": 2.0e-3,
    "cell.noise.table_bias_sigma_m": 1.0e-3,
    "cell.noise.model_deformation_rms_m": 1.0e-3,
    "cell.noise.drives.repeat_sigma_rad": 1.0e-4,
    "faults.object_bump": 0.002,
}
#: The skull's footprint radius about its centre, of the order of the real one [m].
RADIUS_M = 0.1


def _field_names(model: BaseModel) -> set[str]:
    """Every field name in a settings tree."""
    names = set()
    for name in type(model).model_fields:
        names.add(name)
        value = getattr(model, name)
        if isinstance(value, BaseModel):
            names |= _field_names(value)
    return names


@pytest.mark.parametrize("job", ["skull", "assembly"])
@pytest.mark.parametrize("key", sorted(TRUTH_SWEEP))
def test_a_sweep_of_the_truth_leaves_the_planning_settings(job: str, key: str) -> None:
    base = load_config(job)
    swept = load_config(job, {key: TRUTH_SWEEP[key]})
    assert swept != base  # the truth did change
    assert swept.planning() == base.planning()
    p, q = base.planning(), swept.planning()
    assert placement_uncertainty_m(
        q.tolerance, q.placement.lift_m, RADIUS_M
    ) == placement_uncertainty_m(p.tolerance, p.placement.lift_m, RADIUS_M)


def test_the_fixture_tolerance_moves_the_planned_clearance() -> None:
    base = load_config("skull").planning()
    wider = load_config("skull", {"cell.object.tolerance.xy_m": 0.06}).planning()
    m0 = placement_uncertainty_m(base.tolerance, base.placement.lift_m, RADIUS_M)
    m1 = placement_uncertainty_m(wider.tolerance, wider.placement.lift_m, RADIUS_M)
    # hypot(xy, xy) grows by sqrt(2) * 0.03 m; the rest of the margin stays.
    assert m1 - m0 == pytest.approx(2**0.5 * 0.03, abs=1e-12)


def test_the_planning_settings_have_no_section_of_the_truth() -> None:
    names = _field_names(load_config("skull").planning())
    for forbidden in ("noise", "faults", "range_xy_m", "range_yaw_deg", "range_tilt_deg"):
        assert forbidden not in names
    assert {"tolerance", "placement", "localization", "operations"} <= names


def test_a_stage_context_holds_the_controller_api_and_its_settings_only() -> None:
    # ... and the job so far: what the earlier stages found (scenarios.stages.state).
    state = {f.name for f in dataclasses.fields(JobState)}
    assert state == {"model", "calibration", "poses", "scanned", "programs", "refused_by"}
    fields = {f.name: f.type for f in dataclasses.fields(StageContext)}
    assert set(fields) == {
        "controller",
        "virtual",
        "T_table_nominal",
        "box",
        "settings",
        "hooks",
        "state",
        "folder",
        "user",
    }
    assert fields["controller"] == "Controller"
    assert fields["state"] == "JobState"
    assert fields["settings"] == PlanningSettings.__name__
