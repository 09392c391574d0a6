"""Symmetric and degenerate models: the symmetries are found (the model registered to itself)
and reported; a target that a symmetry moves is never accepted, one that it leaves in place
is. Faceted cylinder (128 sections), sphere, square box (4-fold), each without and with
0.05 mm of noise; an asymmetric blob has none."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from registration import MeshModel, match, pose_error
from registration.synthetic import asymmetric_blob, icosphere, partial_scan

NOISE = (0.0, 5e-5)


def _cylinder():
    m = trimesh.creation.cylinder(radius=0.025, height=0.06, sections=128)
    return m.vertices, m.faces


def _sphere():
    v, f = icosphere(5)
    return 0.05 * v, f


def _box():
    m = trimesh.creation.box(extents=(0.04, 0.04, 0.09))
    return m.vertices, m.faces


def _whole_scan(vertices, faces, noise: float, seed: int):
    return partial_scan(vertices, faces, 3000, min_cosine=-1.0, noise=noise, seed=seed)


@pytest.mark.parametrize("noise", NOISE)
def test_faceted_cylinder_turns_and_flips(noise: float) -> None:
    v, f = _cylinder()
    model = MeshModel(v, f)
    scan = _whole_scan(v, f, noise, seed=1)
    r = match(scan.points, model)
    kinds = sorted(s.kind for s in r.symmetries)
    assert kinds == ["axis", "turn"], [s.name for s in r.symmetries]
    axis = next(s for s in r.symmetries if s.kind == "axis")
    assert abs(axis.axis[2]) == pytest.approx(1.0, abs=1e-3)
    flip = next(s for s in r.symmetries if s.kind == "turn")
    assert flip.angle == pytest.approx(np.pi, abs=1e-3) and abs(flip.axis[2]) < 1e-3
    # No targets: the model's symmetry alone makes the pose ambiguous, however exact the fit.
    assert r.verdict == "ambiguous" and "symmetric" in r.reason
    # The centre is left in place by every turn and by the flip: it is located.
    centre = match(scan.points, model, targets=np.zeros((1, 3)))
    assert centre.verdict == "accepted", centre.reason
    # On the axis but off the centre: the end-for-end flip moves it.
    on_axis = match(scan.points, model, targets=[[0.0, 0.0, 0.02]])
    assert on_axis.verdict == "ambiguous" and "half turn" in on_axis.reason
    # Off the axis: every turn about it moves it.
    side = r.predicted_tre([[0.025, 0.0, 0.0], [0.0, 0.0, 0.0]])
    assert side.verdict == ("ambiguous", "accepted")
    assert "free turn (any angle) about the axis" in side.reason[0]
    # Located where it is located: the centre maps back within the predicted TRE.
    T_err = centre.T_model_data @ np.linalg.inv(scan.T_model_data)
    assert np.linalg.norm(T_err[:3, 3]) < 5 * max(centre.targets.tre[0], 1e-5)


@pytest.mark.parametrize("noise", NOISE)
def test_sphere_every_rotation(noise: float) -> None:
    v, f = _sphere()
    model = MeshModel(v, f)
    scan = partial_scan(v, f, 2000, noise=noise, seed=2)  # a cap: local data
    r = match(scan.points, model, targets=[[0.0, 0.0, 0.0], [0.05, 0.0, 0.0]])
    assert [s.kind for s in r.symmetries] == ["sphere"]
    assert r.targets is not None
    assert r.targets.verdict == ("accepted", "ambiguous")
    assert "free rotation (any angle) about the centre" in r.targets.reason[1]
    assert r.verdict == "ambiguous"


@pytest.mark.parametrize("noise", NOISE)
def test_square_box_fourfold(noise: float) -> None:
    v, f = _box()
    model = MeshModel(v, f)
    scan = _whole_scan(v, f, noise, seed=3)
    r = match(scan.points, model)
    # D4: quarter turns about the long axis (two), its half turn, four half turns across.
    turns = [s for s in r.symmetries if s.kind == "turn"]
    assert len(turns) == 7 == len(r.symmetries)
    assert len(r.equivalent_poses) == 7
    quarter = [s for s in turns if abs(s.angle - np.pi / 2) < 1e-3]
    assert len(quarter) == 2 and all(abs(s.axis[2]) > 0.999 for s in quarter)
    # Every equivalent pose fits the data as well as the best one.
    for T in r.equivalent_poses:
        moved = match(scan.points, model, mode="refine", T_init=T, max_iterations=3)
        assert moved.rms == pytest.approx(r.rms, rel=0.05, abs=1e-6)
    assert r.verdict == "ambiguous"
    targets = [[0.0, 0.0, 0.0], [0.0, 0.0, 0.03], [0.02, 0.02, 0.045]]
    assert r.predicted_tre(targets).verdict == ("accepted", "ambiguous", "ambiguous")


@pytest.mark.parametrize("noise", NOISE)
def test_asymmetric_blob_has_none(noise: float) -> None:
    v, f = asymmetric_blob(size=0.15, subdivisions=5, seed=3)
    model = MeshModel(v, f)
    scan = _whole_scan(v, f, noise, seed=4)
    r = match(scan.points, model)
    assert r.symmetries == () and r.equivalent_poses == ()
    assert r.verdict == "accepted", r.reason
    rot, trans = pose_error(r.T_model_data, scan.T_model_data)
    assert np.degrees(rot) < 0.05 and trans < 1e-4


def test_a_perfect_fit_is_not_unique_by_rounding() -> None:
    # Noise-free data on the faceted cylinder: the residual is next to nothing, and so is
    # the cost of its flipped and turned poses. The floor (no noise stated: one part in
    # 10,000 of the size) keeps the covariance's scale from vanishing, and the symmetries
    # found within it make the verdict.
    v, f = _cylinder()
    model = MeshModel(v, f)
    scan = _whole_scan(v, f, 0.0, seed=5)
    r = match(scan.points, model)
    assert r.rms < 1e-6  # metres: far below any sensor
    assert r.floor == pytest.approx(1e-4 * model.extent, rel=0.2)
    assert r.sigma >= r.floor and r.worst_predicted_tre >= r.floor
    assert r.verdict == "ambiguous" and "symmetric" in r.reason
    stated = match(scan.points, model, noise=1e-4)
    assert stated.floor == 1e-4 and stated.sigma >= 1e-4
    assert stated.verdict == "ambiguous" and "symmetric" in stated.reason
