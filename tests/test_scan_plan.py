"""Scan planning in the virtual cell (scan.plan: auto): the virtual cell's rays against the
cell's geometry; the planner on a block whose targets only one side shows, on a sphere whose
turn no scan can see, and the skull job scanned with the passes it chooses. Ground truth is
the geometry (a face's outward normal, a sphere's symmetry) and the evaluator's truth."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import trimesh
from rrd_reader import read_rrd

from cell.irb2400_arm import irb2400
from cell.layout import FixedMesh
from cell.virtual import VirtualCell
from models.robot import RACK_POS, TABLE_TOP_POS
from scenarios.campaign import plan_campaign, run_campaign
from scenarios.jobs import pipeline
from scenarios.jobs.runner import RunOptions, run_job
from scenarios.offline.scan_candidates import PlanningCell, ScanPlanError
from scenarios.offline.scan_passes import ObjectBox
from scenarios.offline.scan_plan import plan_job_scan
from scenarios.offline.settings import Scan
from scenarios.offline.tre_prediction import ErrorModel

#: The planner's errors for the test parts: the configuration's defaults (laser noise, model
#: error over 2 cm, the arm's pass offset), thinned to 3 mm.
ERRORS = ErrorModel(1.0e-4, 2.0e-4, 0.02, 1.7e-4, 0.003, 6000)


def test_a_ray_straight_down_meets_the_table_top_where_the_layout_puts_it() -> None:
    """From 0.3 m above the table frame's origin, straight down: the table top (the layout's
    TABLE_TOP_POS height) at 0.3 m, its normal up; beyond the range, nothing; sideways,
    nothing."""
    cell = VirtualCell.of(irb2400(), RACK_POS)
    cell.set_table(0.0)
    T = cell.T_world_site("table_top")
    assert T[2, 3] == pytest.approx(TABLE_TOP_POS[2], abs=1e-9)
    origin = T[:3, 3] + [0.0, 0.0, 0.3]
    rays = np.array([[0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])
    dist, _normal, _names = cell.cast(origin, rays, 0.2)
    assert np.isinf(dist).all()
    dist, normal, names = cell.cast(origin, rays, 1.0)
    assert dist[0] == pytest.approx(0.3, abs=1e-9)
    np.testing.assert_allclose(normal[0], [0.0, 0.0, 1.0], atol=1e-9)
    assert names[1] == ""


def _plan(
    mesh: trimesh.Trimesh, targets: np.ndarray, section: Scan, acceptable: float | None = None
):
    """The auto plan for `mesh` standing at the table frame's origin (its base on the top);
    a plan short of the goal is scanned if within `acceptable` [m]."""
    T = np.eye(4)
    T[2, 3] = -mesh.bounds[0, 2]
    V, F = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    robot = irb2400()
    cell = VirtualCell.of(robot, RACK_POS, (FixedMesh("object", V, F, T, (V,)),))
    laser = cell.layout.laser
    where = PlanningCell(
        robot.kinematics().for_tool("laser"), cell, ObjectBox.of(V, T), T, robot.q_home,
        robot.joint_speed,
        (laser.directions_tcp(), (laser.range_min_m, laser.range_max_m),
         laser.max_incidence_rad),
    )  # fmt: skip
    return plan_job_scan(where, section, ERRORS, targets, acceptable_tre_m=acceptable)


def _d_cylinder(flat_towards: np.ndarray) -> trimesh.Trimesh:
    """A cylinder (radius 70 mm, 100 mm high) with one flat side 50 mm from its axis, facing
    the horizontal direction `flat_towards`: only the flat tells its turn about the axis."""
    r, h, d = 0.07, 0.1, 0.05
    a = np.linspace(0.0, 2.0 * np.pi, 181)[:-1]
    ring = np.column_stack([r * np.cos(a), r * np.sin(a)])
    half_chord = np.sqrt(r**2 - d**2)
    ring = np.vstack([ring[ring[:, 0] >= -d], [[-d, -half_chord], [-d, half_chord]]])
    heading = np.arctan2(flat_towards[1], flat_towards[0]) - np.pi  # the flat starts at -x
    c, s = np.cos(heading), np.sin(heading)
    ring = ring @ np.array([[c, s], [-s, c]])
    points = np.vstack([np.column_stack([ring, np.zeros(len(ring))]),
                        np.column_stack([ring, np.full(len(ring), h)])])  # fmt: skip
    return trimesh.convex.convex_hull(points)


def _view(tilt_deg: float, heading_deg: float) -> np.ndarray:
    """The laser's view direction of a pass (ScanPass: tilted towards +x, turned about z)."""
    t, h = np.deg2rad(tilt_deg), np.deg2rad(heading_deg)
    return np.array([np.sin(t) * np.cos(h), np.sin(t) * np.sin(h), -np.cos(t)])


@pytest.mark.slow
def test_the_side_that_locates_the_targets_is_the_side_scanned() -> None:
    """A D-shaped cylinder with targets off its axis: its turn about the axis, which moves
    them, shows only on its flat side. The first pass the plan chooses sees the flat (its
    view against the flat's outward normal) and not where the flat is when the part is
    turned a quarter; turned so, the plan turns with it."""
    section = Scan(plan="auto", min_points=100)
    normals = (np.array([-1.0, 0.0, 0.0]), np.array([0.0, -1.0, 0.0]))
    first = []
    for normal in normals:
        part = _d_cylinder(normal)
        z = (part.bounds[1, 2] - part.bounds[0, 2]) / 2
        targets = np.array([[0.04, 0.03, z], [-0.03, 0.04, z], [0.0, -0.045, z]])
        plan = _plan(part, targets, section)
        assert plan.predicted_tre_max_m <= section.planning.goal_tre_m
        first.append(_view(plan.chosen[0].tilt_deg, plan.chosen[0].heading_deg))
    for k, normal in enumerate(normals):
        assert first[k] @ normal < -0.3, (k, first[k])  # it sees its own flat
        assert first[k] @ normals[1 - k] > -0.1, (k, first[k])  # not the other one's


@pytest.mark.slow
def test_a_target_no_pass_constrains_is_named_and_refused() -> None:
    """A sphere turns about its centre unseen by any scan (a fine icosphere: its facets tell
    the turn by hundredths of a millimetre, far below the laser's noise): a target on it
    cannot be located to the goal whatever the passes, and the plan says so, naming it."""
    sphere = trimesh.creation.icosphere(subdivisions=6, radius=0.08)
    with pytest.raises(ScanPlanError, match=r"target 1 .* refuses before any motion"):
        _plan(sphere, np.array([[0.0, 0.0, 0.08]]), Scan(plan="auto", min_points=100))


@pytest.mark.slow
def test_a_goal_out_of_reach_is_scanned_short_of_it_when_the_match_accepts_that() -> None:
    """Asked for 0.05 mm on the D-cylinder, which its 0.2 mm of model error never allows: the
    plan adds passes while one still lowers the worst predicted TRE by 2 % (no candidate
    left would), in under half the budget (the whole budget buys 5 % lower), and is scanned
    since the match accepts up to 1 mm;
    with the match accepting only 0.1 mm, the same plan is refused, naming the targets."""
    from scenarios.offline.tre_prediction import predict_tre

    section = Scan.model_validate(
        {"plan": "auto", "min_points": 100, "planning": {"goal_tre_m": 5e-5}}
    )
    part = _d_cylinder(np.array([-1.0, 0.0, 0.0]))
    z = (part.bounds[1, 2] - part.bounds[0, 2]) / 2
    targets = np.array([[0.04, 0.03, z], [-0.03, 0.04, z], [0.0, -0.045, z]])
    plan = _plan(part, targets, section, acceptable=1e-3)
    worst = plan.predicted_tre_max_m
    assert 5e-5 < worst <= 1e-3
    assert plan.predicted_time_s < 0.5 * section.planning.budget_s  # not spent on crumbs
    chosen_names = {c.name for c in plan.chosen}
    chosen = [c for c in plan.candidates if c.planned.name in chosen_names]
    assert len(chosen) == len(plan.chosen) >= 2
    # Ground truth for the stop: every candidate left, added, lowers the worst by < 2 %.
    for c in plan.candidates:
        if c.planned.name not in chosen_names:
            t, _ = predict_tre([*chosen, c], targets, ERRORS)
            assert np.max(t) > 0.98 * worst, c.planned.name
    with pytest.raises(ScanPlanError, match=r"target \d .* above the 0\.100 mm the match accepts"):
        _plan(part, targets, section, acceptable=1e-4)


def test_a_goal_no_plan_meets_refuses_the_job_before_the_cell_is_built(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Asked for 0.05 mm at every burr hole, which the model error (0.2 mm) never allows,
    with a match that accepts no more than 0.1 mm: the job names the holes and refuses
    before the real cell exists."""

    def refuse(*_args: object, **_kwargs: object) -> None:
        raise AssertionError("the real cell was built")

    monkeypatch.setattr(pipeline, "build_job_cell", refuse)
    overrides = {
        "localization.scan.plan": "auto",
        "localization.scan.planning.goal_tre_m": 5e-5,
        "localization.scan.planning.budget_s": 30.0,
        "localization.registration.max_predicted_tre_m": 1e-4,
    }
    with pytest.raises(ScanPlanError, match=r"kocher_right .* mm predicted above the goal 0\.050"):
        run_job("skull", out=tmp_path, overrides=overrides, options=RunOptions(rrd=False))


def test_the_skull_job_scanned_with_the_chosen_passes_meets_its_goals(
    short_skull_run: Path,
) -> None:
    """scan.plan auto: the passes chosen in the virtual cell predict every target below the
    goal; the job runs them, and its targets, measured against the truth, meet the skull
    goals (RMS <= 0.5 mm, max <= 1 mm).
    The cell time the planner predicts is within 30 % of what the scan took.
    The job is the short skull job with `localization.scan.plan: auto` (tests/conftest.py's
    SHORT_SKULL), run once a session; its run completed (exit status 0)."""
    folder = short_skull_run
    results = json.loads((folder / "results.json").read_text())
    plan = results["scan_plan"]
    assert plan["mode"] == "auto" and plan["passes"] == len(plan["chosen"]) >= 2
    assert plan["predicted_tre_max_m"] <= 3.0e-4
    assert sum(c["information_share"] for c in plan["chosen"]) == pytest.approx(1.0)
    assert plan["scan_time_s"] == pytest.approx(plan["predicted_scan_time_s"], rel=0.3)
    assert results["status"] == "complete"
    assert results["target_error_rms_m"] <= 0.5e-3
    assert results["target_error_max_m"] <= 1.0e-3
    # The figure and the recording show the plan: every candidate's sweep, the chosen ones.
    assert (folder / "scan_plan.png").stat().st_size > 10_000
    plan_path = "/world/cell/table/frame/scan_plan"
    recorded = read_rrd(folder / "run.rrd", (plan_path,))
    (_, candidates), *_ = recorded[f"{plan_path}/candidates"].timed("LineStrips3D:strips")
    (_, chosen), *_ = recorded[f"{plan_path}/chosen"].timed("LineStrips3D:strips")
    assert len(candidates) == plan["candidates"] > len(chosen) == plan["passes"]


@pytest.mark.slow
def test_the_plan_s_predicted_tre_is_calibrated_over_seeds(tmp_path: Path) -> None:
    """Six seeds of the skull job scanned with the chosen passes (the phantom's pose, the
    cell's errors and the phantom's deviation from its model drawn from each seed): the
    registration's error at each target, measured against the truth, over the TRE the
    planner predicted for it before any motion has a median within [0.67, 1.5]; every run
    goes through to the end and meets the largest-error goal (1 mm); and the error budget's
    RMS bound, a 95 % bound, covers the run's true target RMS on at least five of the six
    (a bound that holds at 95 % fails twice in six runs with a probability of 3 %). Seed
    70000 is the one it misses: its calibrated arm leaves 0.46 mm at the pointer, and the
    run ends complete at 0.53 mm RMS against a bound of 0.46 mm."""
    spec = plan_campaign(
        "skull", stage="full", trials=6, seed=70000, vary=["localization.scan.plan=auto"]
    )
    outcome = run_campaign(spec, tmp_path / "campaign", progress=False, workers=2)
    ratios = []
    covered = []
    for row in outcome.rows:
        assert row["run_status"] in ("complete", "at_risk"), row.get("error") or row.get("reason")
        assert row["scan_plan"] == "auto"
        assert row["job_max_m"] <= 1.0e-3
        covered.append(row["job_rms_m"] <= row["budget_rms_bound_m"])
        ratios += [row[f"err_t{k}_m"] / row[f"plan_tre_t{k}_m"] for k in range(row["n_targets"])]
    assert len(ratios) == 24
    assert 0.67 <= float(np.median(ratios)) <= 1.5, sorted(ratios)
    assert sum(covered) >= 5, [(row["seed"], row["job_rms_m"]) for row in outcome.rows]


@pytest.mark.slow
def test_a_transit_that_would_sweep_the_laser_through_the_object_goes_through_home() -> None:
    """Between two passes the arm turns in joint space; where that turn would bring the
    laser or the arm within 10 mm of the object (found along the move every 0.005 rad, four
    times finer than the checker's joint step), the plan routes it through home, and that
    way clears; a transit that clears keeps its direct move. Ground truth: the virtual
    cell's contacts, sampled finely along the joint moves."""
    from cell import nominal_T_base_table
    from scenarios.offline.scan_candidates import candidates
    from scenarios.offline.scan_transits import retreat_q, route_transits

    post = trimesh.creation.box((0.12, 0.12, 0.25))  # a tall post: low passes turn around it
    T = np.eye(4)
    T[2, 3] = 0.125
    V, F = np.asarray(post.vertices), np.asarray(post.faces)
    robot = irb2400()
    cell = VirtualCell.of(robot, RACK_POS, (FixedMesh("object", V, F, T, (V,)),))
    kin = robot.kinematics().for_tool("laser")
    laser = cell.layout.laser
    section = Scan.model_validate(
        {"plan": "auto", "min_points": 100,
         "planning": {"tilts_deg": [50.0, 70.0], "headings_deg": [0, 90, 180, -90],
                      "extra_standoffs_m": []}}
    )  # fmt: skip
    where = PlanningCell(
        kin, cell, ObjectBox.of(V, T), T, robot.q_home, robot.joint_speed,
        (laser.directions_tcp(), (laser.range_min_m, laser.range_max_m),
         laser.max_incidence_rad),
    )  # fmt: skip
    found, _ = candidates(where, section)

    def touches(q0: np.ndarray, q1: np.ndarray, table_m: float) -> bool:
        cell.set_tool("laser")
        cell.set_table(table_m)
        steps = int(np.ceil(np.max(np.abs(q1 - q0)) / 0.005)) + 1
        for s in np.linspace(0.0, 1.0, steps):
            cell.set_joints(q0 + s * (q1 - q0))
            if cell.contacts(0.01):
                return True
        return False

    home = np.asarray(robot.q_home, dtype=float)
    blocked = clear = None
    for a in found:
        for b in found:
            s = b.planned.table_position_m
            if a is b or a.planned.table_position_m != s:
                continue
            if touches(home, home, s) or touches(home, a.planned.q_start, s):
                continue
            q_up = retreat_q(kin, a.planned, nominal_T_base_table)
            if q_up is None:
                continue
            direct = touches(q_up, b.planned.q_start, s)
            if blocked is None and direct:
                if not touches(q_up, home, s) and not touches(home, b.planned.q_start, s):
                    blocked = (a, b)
            elif clear is None and not direct:
                clear = (a, b)
        if blocked and clear:
            break
    assert blocked is not None, "no pair of passes whose direct transit meets the post"
    assert clear is not None
    a, b = blocked
    routed = route_transits(cell, kin, (a.planned, b.planned), robot.q_home)
    assert len(routed[0].q_via) == 0
    assert len(routed[1].q_via) == 1
    np.testing.assert_allclose(routed[1].q_via[0], home)
    a, b = clear
    routed = route_transits(cell, kin, (a.planned, b.planned), robot.q_home)
    assert [len(p.q_via) for p in routed] == [0, 0]


def test_a_pass_with_its_own_standoff_looks_from_that_far() -> None:
    """From above, the laser's TCP sweeps at the pass' stand-off over the box's top (the
    scan's own where the pass gives none)."""
    from scenarios.offline.scan_passes import plan_pass
    from scenarios.offline.settings import ScanPass

    robot = irb2400()
    kin = robot.kinematics().for_tool("laser")
    top = 0.15
    box = ObjectBox(np.array([0.0, 0.0, top / 2]), np.array([0.08, 0.06, top / 2]), 0.1)
    section = Scan(standoff_m=0.28)
    for standoff, expected in ((None, 0.28), (0.36, 0.36), (0.22, 0.22)):
        spec = ScanPass(tilt_deg=0.0, standoff_m=standoff)
        planned = plan_pass(kin, box, section, spec, 0, robot.q_home)
        for T in (planned.T_table_start, planned.T_table_end):
            assert T[2, 3] - top == pytest.approx(expected, abs=1e-9)
            np.testing.assert_allclose(T[:3, 2], [0.0, 0.0, -1.0], atol=1e-9)


@pytest.mark.slow
def test_a_pass_with_no_clear_way_to_it_is_chosen_again_without() -> None:
    """The passes are routed once chosen; a chosen pass the arm finds no clear way to (here
    the cell is told so for the plan's first pass, wherever it stands in the scan) is left
    out and the passes are chosen again from the other candidates: the job is scanned, not
    refused. Ground truth: the greedy choice (choose_passes) from the candidates without it."""
    import scenarios.offline.scan_plan as scan_plan
    from scenarios.offline.scan_choice import choose_passes
    from scenarios.offline.scan_transits import TransitError, route_transits

    part = _d_cylinder(np.array([-1.0, 0.0, 0.0]))
    z = (part.bounds[1, 2] - part.bounds[0, 2]) / 2
    targets = np.array([[0.04, 0.03, z], [-0.03, 0.04, z], [0.0, -0.045, z]])
    section = Scan(plan="auto", min_points=100)
    first = _plan(part, targets, section)
    blocked = next(c for c in first.candidates if c.planned.name == first.chosen[0].name)

    def no_way_to_blocked(cell, kin, passes, *args, **kwargs):  # type: ignore[no-untyped-def]
        line = {blocked.planned.T_table_start[:3, 3].round(6).tobytes(),
                blocked.planned.T_table_end[:3, 3].round(6).tobytes()}  # fmt: skip
        for k, p in enumerate(passes):  # the same line, whichever way it is swept
            if {p.T_table_start[:3, 3].round(6).tobytes(),
                p.T_table_end[:3, 3].round(6).tobytes()} == line:  # fmt: skip
                raise TransitError(f"no clear way to {p.name}", k)
        return route_transits(cell, kin, passes, *args, **kwargs)

    with pytest.MonkeyPatch.context() as patch:  # where the plan routes its passes
        patch.setattr(scan_plan, "route_transits", no_way_to_blocked)
        again = _plan(part, targets, section)
    names = [c.name for c in again.chosen]
    assert blocked.planned.name not in names
    others = tuple(c for c in first.candidates if c is not blocked)
    goal, budget = section.planning.goal_tre_m, section.planning.budget_s
    expected, *_ = choose_passes(
        others, targets, ERRORS, goal, budget, min_gain=section.planning.min_gain
    )
    assert names == [c.planned.name for c in expected]
    assert again.predicted_tre_max_m <= goal
