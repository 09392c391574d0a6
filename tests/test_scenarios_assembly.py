"""The assembly job end to end in physics: IR edge probing (2D) and surface matching (3D) of
the bracket, grasp, tool change, screws driven with each method's pose; the numbers are
checked against the truth read here."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cell import CellConfig, FixedMesh, LooseMesh, make_cell, nominal_T_base_table
from models import builtin_model
from registration import pose_error
from scenarios.assembly import BRACKET_PLATE_M, BRACKET_PROBES
from scenarios.config import AssemblyConfig
from scenarios.probing import EdgeNotFoundError, pose_from_edges, probe_part
from scenarios.runner import RunOptions, run_job


def _R(yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def test_pose_from_edges_recovers_a_known_pose() -> None:
    """Edge points generated from a known pose (on the part's edge lines) give that pose."""
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = _R(0.07), [0.012, -0.008, 0.0]
    # Points on the three edges, in the probes' order: the front edge (y = 25 mm) twice,
    # the left edge (x = -40 mm) once, anywhere along each edge.
    p_part = np.array([[-0.021, 0.025, 0.0], [0.011, 0.025, 0.0], [-0.040, 0.013, 0.0]])
    points = p_part @ T[:3, :3].T + T[:3, 3]
    estimate = pose_from_edges(BRACKET_PROBES, points, 0.0)
    rotation, translation = pose_error(estimate, T)
    assert rotation < 1e-12 and translation < 1e-12


def test_ir_probing_finds_the_bracket_in_an_ideal_cell() -> None:
    bracket = builtin_model("bracket")
    T_true = np.eye(4)
    T_true[:3, :3], T_true[:3, 3] = _R(np.deg2rad(4.0)), [0.009, -0.011, 0.0]
    fixture = FixedMesh("part", bracket.mesh.vertices, bracket.mesh.faces, T_true)
    controller, truth = make_cell(CellConfig(seed=3, fixtures=(fixture,)).ideal())
    result = probe_part(controller, BRACKET_PROBES, np.eye(4), 0.03, BRACKET_PLATE_M)
    rotation, translation = pose_error(result.T_table_object, T_true)
    # Bisection to 0.1 mm on each edge, positions from the encoders; no noise: the pose
    # within 0.15 mm and 0.1 deg.
    assert translation < 1.5e-4 and np.degrees(rotation) < 0.1
    assert result.readings == 33
    # A part that is not there: the first probe line finds no edge and says so.
    empty, _ = make_cell(CellConfig(seed=3).ideal())
    with pytest.raises(EdgeNotFoundError, match="no edge between"):
        probe_part(empty, BRACKET_PROBES, np.eye(4), 0.03, BRACKET_PLATE_M)
    assert isinstance(truth.T_base_table(), np.ndarray)


@pytest.fixture(scope="module")
def results(tmp_path_factory: pytest.TempPathFactory) -> dict:
    out = tmp_path_factory.mktemp("runs")
    folder, res = run_job(AssemblyConfig(seed=2), out=out, options=RunOptions(rrd=True))
    res["folder"] = str(folder)
    return res


def test_assembly_run_completes_with_both_methods(results: dict) -> None:
    assert results["status"] == "complete"
    folder = Path(results["folder"])
    for name in ("config.yaml", "results.json", "scan.ply", "program.mod", "run.rrd"):
        assert (folder / name).is_file(), name
    assert json.loads((folder / "results.json").read_text())["status"] == "complete"
    methods = results["methods"]
    assert set(methods) == {"ir_2d", "laser_3d"}
    assert methods["ir_2d"]["ir_readings"] == 33
    for row in methods.values():
        assert len(row["targets"]) == 2  # the two screws driven from above
        # Tolerances with the default noise: pose within 1 deg / 2 mm, screws within 2 mm.
        assert row["rotation_error_deg"] < 1.0 and row["translation_error_m"] < 2e-3
        assert row["target_error_max_m"] < 2e-3
    assert results["grasp_error_m"] < 2e-3


def test_assembly_pose_errors_agree_with_an_independent_truth(results: dict) -> None:
    """Rebuild the real cell from the seed (same draws, the part loose on the table and
    settled as built) and compare the reported 3D pose error with one computed here from the
    truth and the estimated pose."""
    from models import ModelErrorSpec, real_model
    from scenarios.assembly import screw_holes
    from scenarios.placement import draw_true_pose
    from scenarios.skull import cell_config

    config = AssemblyConfig(seed=2)
    model = builtin_model("bracket")
    virtual = model.__class__(**{**model.__dict__, "burr_holes": screw_holes(model)})
    spec = ModelErrorSpec(
        deformation_rms=config.noise.model_deformation_rms_m,
        noise_rms=config.noise.model_noise_rms_m,
    )
    real, _ = real_model(virtual, spec, seed=config.seed)
    rng = np.random.default_rng(np.random.SeedSequence([config.seed, 6]))
    T_table_true = draw_true_pose(config.placement, real.mesh.vertices, rng)
    part = LooseMesh(
        "part",
        real.mesh.vertices,
        real.mesh.faces,
        T_table_true,
        convex_pieces=tuple(p.vertices for p in real.convex_pieces),
    )
    _, truth = make_cell(replace(cell_config(config.noise, config.seed, ()), parts=(part,)))
    T_estimate = np.array(
        json.loads((Path(results["folder"]) / "results.json").read_text())["registration"][
            "T_table_object"
        ]
    )
    rotation, translation = pose_error(
        nominal_T_base_table(0.0) @ T_estimate, truth.T_base_object("part")
    )
    reported = results["registration"]
    assert np.degrees(rotation) == pytest.approx(reported["rotation_error_deg"], abs=0.01)
    # The table's per-move repeatability (0.01 mm sigma) and the part's creep while the
    # table carried it through the probing and the scan separate the two truths.
    assert translation == pytest.approx(reported["translation_error_m"], abs=1e-4)
