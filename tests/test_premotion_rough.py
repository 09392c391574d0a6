"""The pre-motion check on a rough, CT-like bone surface: the skull phantom with bumps (0.3 mm
RMS, 3-8 mm wavelengths) and a shallow dent (2.5 mm deep, 6 mm sigma) at each burr hole's
entry, where its convex pieces (24, on about 5 mm voxels) stand proud of the bone. A program
whose tool clears the bone passes, one whose tool enters it is refused, each by the depth the
exact mesh gives (libigl's signed distance of the tip ball's centre, computed here); with the
pieces alone the clearing program is refused as the bone's would be."""

from __future__ import annotations

from dataclasses import replace

import igl
import numpy as np
import pytest

from cell.irb2400_arm import irb2400
from models.convex import convex_pieces
from models.mesh import TriangleMesh
from models.model import ObjectModel
from models.robot import RACK_POS, SCREWER
from models.targets import BurrHole
from registration import transform_points
from scenarios.configuration.config_files import load_config
from scenarios.jobs.job_plan import object_models
from scenarios.offline.job_cell import job_virtual_cell
from scenarios.offline.nominal_placement import nominal_pose
from scenarios.offline.premotion import check_program
from scenarios.offline.premotion_verdict import PremotionCheck
from scenarios.offline.program_plan import burr_hole_operations, plan_program
from scenarios.program.program_types import OfflineProgram

#: The screwer's pointer: a 3 mm ball whose centre is the TCP (models/robot/tools.py).
TIP_RADIUS_M = 0.003
DENT_M, DENT_SIGMA_M = 0.0025, 0.006


def rough_skull() -> ObjectModel:
    """The shipped skull's virtual model made rough (see the module's docstring), with its
    convex pieces and its burr holes' entries moved onto the dents' floors."""
    virtual, _ = object_models(load_config("skull"))
    tm = virtual.mesh.to_trimesh()
    V, N = np.asarray(tm.vertices), np.asarray(tm.vertex_normals)
    rng = np.random.default_rng(5)
    k = rng.normal(size=(12, 3))
    k *= 2 * np.pi / rng.uniform(0.003, 0.008, (12, 1)) / np.linalg.norm(k, axis=1)[:, None]
    bumps = 0.0003 * np.sin(V @ k.T + rng.uniform(0, 2 * np.pi, 12)).sum(axis=1) / np.sqrt(6)
    dents = np.zeros(len(V))
    for h in virtual.burr_holes:
        dents -= DENT_M * np.exp(-np.sum((V - h.p_entry) ** 2, axis=1) / (2 * DENT_SIGMA_M**2))
    mesh = TriangleMesh(V + N * (bumps + dents)[:, None], np.asarray(tm.faces))
    F = np.asarray(mesh.faces, dtype=np.int64)
    holes = []
    for h in virtual.burr_holes:
        floor = (h.p_entry - DENT_M * h.direction)[None]
        _, _, c = igl.point_mesh_squared_distance(floor, np.asarray(mesh.vertices), F)
        holes.append(BurrHole(h.name, c[0], h.direction, h.depth))
    return replace(virtual, mesh=mesh, convex_pieces=convex_pieces(mesh), burr_holes=tuple(holes))


@pytest.fixture(scope="module")
def rough() -> dict:
    config = load_config("skull")
    model = rough_skull()
    T_table_object = nominal_pose(config.cell.object.placement, model.mesh.vertices)
    robot = irb2400()
    return {"config": config, "model": model, "T": T_table_object, "robot": robot,
            "kin": robot.kinematics()}  # fmt: skip


def _program(rough: dict, touch_offset_m: float) -> OfflineProgram:
    section = rough["config"].operations
    operations = burr_hole_operations(rough["model"].burr_holes, section.approach_m, touch_offset_m)
    return plan_program(rough["kin"].for_tool(section.tool), SCREWER.T_tool_tcp, section.tool,
                        operations, rough["T"], rough["robot"].q_home, section.spins)  # fmt: skip


def _check(rough: dict, program: OfflineProgram, exact_band_m: float = 0.02) -> PremotionCheck:
    cell = job_virtual_cell(rough["robot"], RACK_POS, rough["model"], rough["T"],
                            exact_band_m=exact_band_m)  # fmt: skip
    return check_program(program, rough["kin"], cell, rough["robot"].q_home, SCREWER.T_tool_tcp)


def _true_gaps(rough: dict, program: OfflineProgram) -> np.ndarray:
    """The tip ball's signed distance [m] from the rough bone at each touch (libigl on the
    mesh, the ball's radius off): the ground truth."""
    mesh = rough["model"].mesh
    tips = np.array([op.T_base_touch[:3, 3] for op in program.operations])
    p = transform_points(np.linalg.inv(program.T_base_object), tips)
    S = igl.signed_distance(p, np.asarray(mesh.vertices), np.asarray(mesh.faces, dtype=np.int64),
                            sign_type=igl.SIGNED_DISTANCE_TYPE_FAST_WINDING_NUMBER)[0]  # fmt: skip
    return np.asarray(S) - TIP_RADIUS_M


def test_the_pieces_stand_proud_of_the_rough_bone_at_the_entries(rough: dict) -> None:
    """The premise: at the entries the convex pieces lie more than 0.5 mm above the bone
    (their signed distance from a point 10 mm out along each hole is smaller than the
    bone's)."""
    from scipy.spatial import ConvexHull

    model = rough["model"]
    V, F = np.asarray(model.mesh.vertices), np.asarray(model.mesh.faces, dtype=np.int64)
    for hole in model.burr_holes:
        out = hole.p_entry - 0.01 * hole.direction
        bone = float(np.sqrt(igl.point_mesh_squared_distance(out[None], V, F)[0][0]))
        # The distance along the hole's line to the first piece it enters.
        nearest = np.inf
        for piece in model.convex_pieces:
            eq = ConvexHull(np.asarray(piece.vertices)).equations  # n.x + d <= 0 inside
            denom, num = eq[:, :3] @ hole.direction, -(eq[:, :3] @ out + eq[:, 3])
            enter = np.max(np.where(denom < 0, num / np.where(denom < 0, denom, 1), -np.inf))
            leave = np.min(np.where(denom > 0, num / np.where(denom > 0, denom, 1), np.inf))
            if enter <= leave and leave > 0:
                nearest = min(nearest, max(enter, 0.0))
        assert bone - nearest > 0.5e-3, (hole.name, bone, nearest)


def test_a_tool_that_clears_the_rough_bone_passes(rough: dict) -> None:
    """The shipped job's touch (the ball 1 mm short of the entry along the hole): the tip
    clears the bone by 0.7-1 mm (truth), and the check passes, measuring each gap as the
    truth less at most 0.05 mm; with the convex pieces alone it is refused."""
    program = _program(rough, rough["config"].operations.touch_offset_m)
    truth = _true_gaps(rough, program)
    assert np.all(truth > 0.5e-3), truth
    check = _check(rough, program)
    assert check.ok, check.summary
    gaps = np.array([m.touch_gap_m for m in check.moves if m.name.endswith("-> touch")])
    assert np.all((gaps <= truth + 1e-6) & (gaps >= truth - 5e-5)), (gaps, truth)
    proxy = _check(rough, program, exact_band_m=0.0)
    assert not proxy.ok and "tool_screwer touches object" in proxy.summary


def test_a_tool_that_enters_the_rough_bone_is_refused_by_its_depth(rough: dict) -> None:
    """The ball 0.5 mm past the entry along the hole: it enters the bone at every hole
    (truth), and every line into a touch is refused, the depth measured as the truth gives
    it (to 0.05 mm)."""
    program = _program(rough, 0.0025)
    truth = _true_gaps(rough, program)
    assert np.all(truth < -0.2e-3), truth
    check = _check(rough, program)
    assert not check.ok
    gaps = np.array([m.touch_gap_m for m in check.moves if m.name.endswith("-> touch")])
    assert np.all((gaps <= truth + 1e-6) & (gaps >= truth - 5e-5)), (gaps, truth)
    refused = {p.move for p in check.problems if "tool_screwer touches object" in p.detail}
    assert refused >= {f"{op.operation.name}: approach -> touch" for op in program.operations}
