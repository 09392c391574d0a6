"""User meshes: round trips in mm and m, checks of what was loaded, and every bad input."""

from __future__ import annotations

import struct

import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

from models.mesh import TriangleMesh
from models.mesh_export import write_mesh
from models.model_errors import MeshDataError, MeshFileError, ModelParameterError, UnknownModelError
from models.registry import builtin_model, load_model
from models.user_mesh import load_mesh_file


@pytest.fixture(scope="module")
def bracket():
    return builtin_model("bracket")


def _same_surface(a: TriangleMesh, b: TriangleMesh, tol: float) -> None:
    """Same vertex set within `tol` [m] (either way), same triangle count and volume."""
    d_ab, _ = cKDTree(b.vertices).query(a.vertices)
    d_ba, _ = cKDTree(a.vertices).query(b.vertices)
    assert max(d_ab.max(), d_ba.max()) < tol
    assert len(a.faces) == len(b.faces)
    assert a.to_trimesh().volume == pytest.approx(b.to_trimesh().volume, rel=1e-5)


@pytest.mark.parametrize("suffix", [".stl", ".obj", ".ply"])
@pytest.mark.parametrize("units", ["mm", "m"])
def test_round_trip_in_mm_and_m(tmp_path, bracket, suffix, units) -> None:
    path = write_mesh(bracket.mesh, tmp_path / f"bracket{suffix}", units)
    raw = trimesh.load(path, force="mesh", process=False)
    # The file holds the part in the requested units: 80 mm long.
    assert raw.extents.max() == pytest.approx(80.0 if units == "mm" else 0.080, rel=1e-6)
    model, report = load_mesh_file(path, units=units)
    _same_surface(model.mesh, bracket.mesh, tol=1e-7)  # float32 STL: 0.1 um at 80 mm
    assert report.warnings == ()
    assert model.mesh.to_trimesh().is_watertight
    assert len(model.convex_pieces) >= 2  # an L is not convex


def test_scale_factor_is_metres_per_file_unit(tmp_path, bracket) -> None:
    path = write_mesh(bracket.mesh, tmp_path / "b.ply", "mm")
    by_name, _ = load_mesh_file(path, units="mm")
    by_factor, _ = load_mesh_file(path, units=1e-3)
    np.testing.assert_allclose(by_factor.mesh.vertices, by_name.mesh.vertices)
    inches, _ = load_mesh_file(write_mesh(bracket.mesh, tmp_path / "c.ply", 0.0254), "in")
    _same_surface(inches.mesh, bracket.mesh, tol=1e-8)


def test_wrong_units_are_refused_with_a_hint(tmp_path, bracket) -> None:
    mm_file = write_mesh(bracket.mesh, tmp_path / "b.stl", "mm")
    with pytest.raises(MeshDataError, match=r"80 m looks like the wrong units.*--units mm"):
        load_mesh_file(mm_file, units="m")
    m_file = write_mesh(bracket.mesh, tmp_path / "c.stl", "m")
    with pytest.raises(MeshDataError, match=r"wrong units.*--units m\b"):
        load_mesh_file(m_file, units="mm")  # 0.08 mm


def test_the_hint_speaks_the_users_language(tmp_path, bracket) -> None:
    # A job's object read with the units of its configuration: the hint names that key,
    # as the user would write it in the job's YAML.
    from scenarios.offline.operations import virtual_model

    m_file = write_mesh(bracket.mesh, tmp_path / "c.stl", "m")
    with pytest.raises(MeshDataError, match=r"wrong units \(with cell\.object\.units: m it"):
        virtual_model(str(m_file), "mm", None, "touch", 0)
    with pytest.raises(MeshDataError, match=r"wrong units \(with --units m it"):
        load_mesh_file(m_file, units="mm")


def test_borderline_size_is_a_warning(tmp_path) -> None:
    box = trimesh.creation.box(extents=(5.0, 4.0, 3.0))  # a 5 mm cube read in mm
    box.export(tmp_path / "tiny.stl")
    model, report = load_mesh_file(tmp_path / "tiny.stl", units="mm")
    assert model.mesh.extents.max() == pytest.approx(0.005)
    assert any("wrong units" in w for w in report.warnings)


def test_open_mesh_degenerate_and_duplicate_faces_are_reported(tmp_path) -> None:
    box = trimesh.creation.box(extents=(50.0, 40.0, 30.0))
    faces = np.asarray(box.faces)[1:]  # open: one triangle missing
    vertices = np.vstack([box.vertices, [[0.0, 0.0, 0.0]]])
    extra = np.array([[0, 0, 1], [8, 8, 8], faces[0]])  # two degenerate, one duplicate
    trimesh.Trimesh(vertices, np.vstack([faces, extra]), process=False).export(
        tmp_path / "open.obj"
    )
    model, report = load_mesh_file(tmp_path / "open.obj", units="mm")
    assert report.degenerate_faces_removed == 2
    assert report.duplicate_faces_removed == 1
    assert len(model.mesh.faces) == 11
    assert any("not watertight" in w for w in report.warnings)
    assert not model.mesh.to_trimesh().is_watertight
    assert len(model.convex_pieces) >= 1


def test_inward_faces_are_flipped_with_a_warning(tmp_path) -> None:
    box = trimesh.creation.box(extents=(50.0, 40.0, 30.0))
    box.invert()
    box.export(tmp_path / "inside_out.stl")
    model, report = load_mesh_file(tmp_path / "inside_out.stl", units="mm")
    assert model.mesh.to_trimesh().volume == pytest.approx(50 * 40 * 30 * 1e-9)
    assert any("flipped" in w for w in report.warnings)


def test_large_meshes_are_decimated_for_contact_only(tmp_path) -> None:
    sphere = trimesh.creation.icosphere(subdivisions=5, radius=40.0)  # 20480 faces, mm
    sphere.export(tmp_path / "ball.ply")
    model, report = load_mesh_file(tmp_path / "ball.ply", units="mm", contact_max_faces=2000)
    assert len(model.mesh.faces) == 20480  # the full mesh serves rays and registration
    assert report.contact_faces <= 2000
    assert len(model.convex_pieces) == 1  # a ball is convex
    hull = model.convex_pieces[0].to_trimesh()
    assert hull.volume == pytest.approx(4 / 3 * np.pi * 0.04**3, rel=0.03)


def _write(path, data: bytes):
    path.write_bytes(data)
    return path


def test_missing_file(tmp_path) -> None:
    with pytest.raises(MeshFileError, match="no such file"):
        load_mesh_file(tmp_path / "absent.stl")


def test_empty_file(tmp_path) -> None:
    with pytest.raises(MeshFileError, match="empty"):
        load_mesh_file(_write(tmp_path / "empty.stl", b""))


@pytest.mark.parametrize(
    ("name", "data"),
    [
        ("garbage.stl", b"this is not an stl file at all\n" * 4),
        ("garbage.ply", b"this is not a ply file\n"),
        ("garbage.obj", b"\x00\x01\x02 not an obj\n"),
        # binary STL whose header announces 1000 triangles but holds one
        ("truncated.stl", b"\0" * 80 + struct.pack("<I", 1000) + b"\0" * 50),
    ],
)
def test_corrupt_files(tmp_path, name, data) -> None:
    with pytest.raises(MeshFileError, match=name.replace(".", r"\.")):
        load_mesh_file(_write(tmp_path / name, data))


def test_file_that_is_not_a_mesh(tmp_path) -> None:
    with pytest.raises(MeshFileError, match=r"not a mesh file.*\.stl"):
        load_mesh_file(_write(tmp_path / "notes.txt", b"hello"))
    with pytest.raises(MeshFileError, match="no triangles"):  # a point cloud in OBJ
        load_mesh_file(_write(tmp_path / "points.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\n"))
    with pytest.raises(MeshFileError, match="not a file"):
        load_mesh_file(tmp_path)


def test_nan_vertices(tmp_path) -> None:
    data = b"v 0 0 0\nv nan 0 0\nv 0 10 0\nv 0 0 10\nf 1 2 3\nf 1 3 4\n"
    with pytest.raises(MeshDataError, match="1 of 4 vertices are NaN"):
        load_mesh_file(_write(tmp_path / "nan.obj", data))
    with pytest.raises(MeshDataError, match="NaN"):
        TriangleMesh(np.array([[0, 0, 0], [np.nan, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]))


def test_bad_mesh_arrays_and_units() -> None:
    with pytest.raises(MeshDataError, match="indices"):
        TriangleMesh(np.zeros((3, 3)), np.array([[0, 1, 3]]))
    with pytest.raises(MeshDataError, match="shape"):
        TriangleMesh(np.zeros((3, 2)), np.array([[0, 1, 2]]))
    with pytest.raises(ModelParameterError, match="mm"):
        load_mesh_file("whatever.stl", units="furlong")
    with pytest.raises(ModelParameterError, match="positive"):
        load_mesh_file("whatever.stl", units=-1.0)


def test_unknown_name_lists_the_valid_ones() -> None:
    with pytest.raises(UnknownModelError, match=r"'skul'.*'skull'.*\.stl"):
        load_model("skul")


def test_write_is_complete_or_nothing(tmp_path, bracket) -> None:
    with pytest.raises(MeshFileError, match="does not exist"):
        write_mesh(bracket.mesh, tmp_path / "no" / "dir.stl")
    with pytest.raises(MeshFileError, match="suffix"):
        write_mesh(bracket.mesh, tmp_path / "b.step")
    target = tmp_path / "taken.stl"
    target.mkdir()  # the name is a folder: the rename fails, nothing is left behind
    with pytest.raises(MeshFileError, match="cannot write"):
        write_mesh(bracket.mesh, target)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["taken.stl"]
    assert list(target.iterdir()) == []
