"""Scanner and CAD files: each reader against files written by the format's reference
library (pye57, laspy, trimesh; PCD by Open3D, committed in tests/data/pcd), the units, and
every kind of bad file refused with one line naming the file."""

from __future__ import annotations

from pathlib import Path

import laspy
import numpy as np
import pye57
import pytest
import trimesh

from registration import FormatError, load_model, load_points
from registration.io import load_targets

PCD = Path(__file__).parent / "data" / "pcd"
REFERENCE = np.load(PCD / "points.npy")  # the points the PCD files were written from [m]


@pytest.fixture(scope="module")
def points() -> np.ndarray:
    rng = np.random.default_rng(3)
    return rng.uniform([-0.05, -0.03, 0.0], [0.05, 0.03, 0.02], size=(400, 3))


def _write_e57(path: Path, points: np.ndarray, translation=(0.0, 0.0, 0.0)) -> None:
    e57 = pye57.E57(str(path), mode="w")
    data = {"cartesianX": points[:, 0], "cartesianY": points[:, 1], "cartesianZ": points[:, 2]}
    e57.write_scan_raw(data, translation=np.asarray(translation, dtype=float))
    e57.close()


def _write_las(path: Path, points: np.ndarray) -> None:
    header = laspy.LasHeader(point_format=3, version="1.2")
    header.scales = np.array([1e-6, 1e-6, 1e-6])
    header.offsets = points.min(axis=0)
    las = laspy.LasData(header)
    las.x, las.y, las.z = points[:, 0], points[:, 1], points[:, 2]
    las.write(path)


@pytest.mark.parametrize("data", ["ascii", "binary", "binary_compressed"])
def test_pcd_written_by_open3d(data: str) -> None:
    read = load_points(PCD / f"cloud_{data}.pcd")
    np.testing.assert_allclose(read, REFERENCE, atol=1e-8)  # float32 in the file


def test_e57_written_by_pye57_with_its_pose(tmp_path, points) -> None:
    _write_e57(tmp_path / "scan.e57", points, translation=(0.1, 0.0, 0.0))
    read = load_points(tmp_path / "scan.e57")
    np.testing.assert_allclose(read, points + np.array([0.1, 0.0, 0.0]), atol=1e-9)


@pytest.mark.parametrize("suffix", [".las", ".laz"])
def test_las_and_laz_written_by_laspy(tmp_path, points, suffix: str) -> None:
    _write_las(tmp_path / f"scan{suffix}", points)
    np.testing.assert_allclose(load_points(tmp_path / f"scan{suffix}"), points, atol=1e-6)


def test_ply_point_cloud_and_range_mesh(tmp_path, points) -> None:
    trimesh.PointCloud(points).export(tmp_path / "cloud.ply")
    np.testing.assert_allclose(load_points(tmp_path / "cloud.ply"), points, atol=1e-12)
    # A range scan stored as a mesh (a grid of triangles): its vertices are the points.
    grid = trimesh.creation.box(extents=(0.05, 0.04, 0.03))
    grid.export(tmp_path / "range.ply")
    np.testing.assert_allclose(load_points(tmp_path / "range.ply"), grid.vertices, atol=1e-12)


def test_text_files_and_units(tmp_path, points) -> None:
    np.savetxt(tmp_path / "scan.xyz", points * 1e3, header=str(len(points)), comments="")
    np.testing.assert_allclose(load_points(tmp_path / "scan.xyz", units="mm"), points)
    np.savetxt(tmp_path / "scan.csv", points, delimiter=",", header="x,y,z", comments="")
    np.testing.assert_allclose(load_points(tmp_path / "scan.csv"), points)
    mesh = trimesh.creation.icosphere(subdivisions=3, radius=40.0)  # mm
    mesh.export(tmp_path / "model.stl")
    model = load_model(tmp_path / "model.stl", units="mm")
    assert model.extent == pytest.approx(np.linalg.norm([0.08] * 3), rel=0.01)


def test_the_count_line_must_match_the_rows(tmp_path) -> None:
    (tmp_path / "short.xyz").write_text("100\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n")
    with pytest.raises(FormatError, match=r"count line says 100 points, but it holds 4 rows"):
        load_points(tmp_path / "short.xyz", units="mm")


def test_targets_in_json_or_points(tmp_path) -> None:
    (tmp_path / "plan.json").write_text('{"entry": [10, 0, 5], "target": [12, 1, -3]}')
    names, pts = load_targets(tmp_path / "plan.json", units="mm")
    assert names == ("entry", "target")
    np.testing.assert_allclose(pts, [[0.01, 0.0, 0.005], [0.012, 0.001, -0.003]])


def _bad_files(tmp: Path, points: np.ndarray) -> dict[str, tuple[Path, str]]:
    """Bad files of every kind, and a part of the message each must raise."""
    cases: dict[str, tuple[Path, str]] = {}
    (tmp / "empty.xyz").write_text("")
    cases["empty"] = (tmp / "empty.xyz", "the file is empty")
    (tmp / "nan.xyz").write_text("0 0 0\n0.01 nan 0\n0 0.01 0\n")
    cases["nan"] = (tmp / "nan.xyz", "NaN or inf")
    (tmp / "words.csv").write_text("x,y,z\n0,0,0\nhello,1,2\n")
    cases["words"] = (tmp / "words.csv", "expected numbers")
    np.save(tmp / "flat.npy", np.zeros((4, 2)))
    cases["npy shape"] = (tmp / "flat.npy", "(N, 3)")
    (tmp / "header.pcd").write_text("hello\n1 2 3\n")
    cases["pcd header"] = (tmp / "header.pcd", "not a PCD file")
    (tmp / "header.ply").write_text("plx\nformat ascii 1.0\n")
    cases["ply header"] = (tmp / "header.ply", "not a PLY file")
    for name in ("cloud_binary.pcd",):
        data = (PCD / name).read_bytes()
        (tmp / "cut.pcd").write_bytes(data[: len(data) * 2 // 3])
        cases["truncated pcd"] = (tmp / "cut.pcd", "cut.pcd")
    trimesh.PointCloud(points).export(tmp / "full.ply")
    data = (tmp / "full.ply").read_bytes()
    (tmp / "cut.ply").write_bytes(data[: len(data) * 2 // 3])
    cases["truncated ply"] = (tmp / "cut.ply", "cut.ply")
    _write_e57(tmp / "full.e57", points)
    data = (tmp / "full.e57").read_bytes()
    (tmp / "cut.e57").write_bytes(data[: len(data) * 2 // 3])
    cases["truncated e57"] = (tmp / "cut.e57", "cannot be read as E57")
    _write_las(tmp / "full.las", points)
    data = (tmp / "full.las").read_bytes()
    (tmp / "cut.las").write_bytes(data[: len(data) * 2 // 3])
    cases["truncated las"] = (tmp / "cut.las", "cannot be read as LAS")
    np.savetxt(tmp / "in_mm.xyz", points * 1e6)  # micrometres read as metres: 100 m
    cases["units"] = (tmp / "in_mm.xyz", "looks like the wrong units")
    return cases


def test_every_bad_file_is_named_with_its_problem(tmp_path, points) -> None:
    for label, (path, message) in _bad_files(tmp_path, points).items():
        with pytest.raises(FormatError) as caught:
            load_points(path)
        text = str(caught.value)
        assert str(path) in text, (label, text)
        assert message in text, (label, text)
        assert "\n" not in text, label
