"""Targets of a user's mesh: a targets file beside it (in the mesh's units) or targets
generated on its upper surface."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh

from models.mesh import TriangleMesh
from models.model import ObjectModel
from scenarios.offline.mesh_targets import (
    TargetsFileError,
    generate_targets,
    read_targets,
    targets_path,
)


def test_targets_file_is_read_in_the_mesh_units(tmp_path: Path) -> None:
    mesh = tmp_path / "phantom.stl"
    assert targets_path(mesh) == tmp_path / "phantom.targets.yaml"
    path = targets_path(mesh)
    path.write_text(
        "- {name: a, entry: [10, 20, 30], direction: [0, 0, -2], depth: 40}\n"
        "- {name: b, entry: [0, 0, 50], direction: [1, 0, -1], depth: 15}\n"
    )
    holes = read_targets(path, "mm")
    assert [h.name for h in holes] == ["a", "b"]
    assert np.allclose(holes[0].p_entry, [0.010, 0.020, 0.030])
    assert np.allclose(holes[0].direction, [0, 0, -1])  # normalised
    assert holes[0].depth == pytest.approx(0.040)
    assert np.allclose(holes[1].direction, np.array([1, 0, -1]) / np.sqrt(2))


def test_bad_targets_files_name_the_problem(tmp_path: Path) -> None:
    path = tmp_path / "t.targets.yaml"
    path.write_text("- {name: a, entry: [1, 2, 3], depth: 4}\n")
    with pytest.raises(TargetsFileError, match=r"target 0 must have keys .*'direction'"):
        read_targets(path, "mm")
    path.write_text("[]\n")
    with pytest.raises(TargetsFileError, match="non-empty list"):
        read_targets(path, "mm")
    path.write_text("- {name: a, entry: [1, 2], direction: [0, 0, 1], depth: 4}\n")
    with pytest.raises(Exception, match="3-vector"):
        read_targets(path, "mm")
    assert isinstance(TargetsFileError("x"), ValueError)


def test_generated_targets_lie_on_the_upper_surface_pointing_in() -> None:
    sphere = trimesh.creation.icosphere(subdivisions=4, radius=0.08)
    model = ObjectModel("ball", TriangleMesh(sphere.vertices, sphere.faces), ())
    holes = generate_targets(model, count=4, seed=1)
    assert len(holes) == 4
    for hole in holes:
        p = hole.p_entry
        assert np.linalg.norm(p) == pytest.approx(0.08, abs=1e-9)  # on the surface
        assert p[2] > 0.08 * 0.33  # top third of the height
        assert np.allclose(hole.direction, -p / np.linalg.norm(p), atol=0.02)  # inward normal
    spread = min(
        np.linalg.norm(a.p_entry - b.p_entry) for i, a in enumerate(holes) for b in holes[i + 1 :]
    )
    assert spread > 0.02  # spread over the cap, not clustered
