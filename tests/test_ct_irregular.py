"""CT series as scanners write them: slice steps of 1 and 7 mm mixed, the gantry tilted 0, 15
and 30 deg. Each series is written as DICOM files here (pydicom), its pixels the partial
volume of a known ellipsoid over each pixel and slice thickness; the reader resamples it onto
a regular grid and the bone mesh must lie on the analytic ellipsoid within a third of the
largest step (both ways: the mesh's vertices from the ellipsoid, and the ellipsoid's points
from the mesh). A gap of missing slices is refused, naming it; nothing is written."""

from __future__ import annotations

from pathlib import Path

import nibabel as nib
import numpy as np
import pydicom
import pytest
from igl import point_mesh_squared_distance
from pydicom.dataset import FileMetaDataset
from pydicom.uid import CTImageStorage, ExplicitVRLittleEndian, generate_uid
from scipy import ndimage
from scipy.spatial import cKDTree

from models.ct import VolumeError, bone_model, read_volume
from models.ct.regular import voxel_size
from models.ct.volume import RAS_FROM_LPS
from scenarios.cli.app import main

#: The ellipsoid's semi-axes along the patient's x, y, z [mm], centred at the origin.
AXES_MM = np.array([30.0, 24.0, 20.0])
#: Steps between slices along their normal: 1 and 7 mm mixed, about 70 mm in all.
STEPS_MM = [1.0] * 6 + [7.0] * 2 + [1.0] * 5 + [7.0] * 3 + [1.0] * 4 + [7.0] * 2 + [1.0] * 8
PIXEL_MM = 0.8
COLUMNS = ROWS = 120


def _sdf(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First-order signed distance [mm] of points (..., 3) from the ellipsoid (exact on the
    surface, good near it) and its unit gradient."""
    q = np.sqrt(np.sum((p / AXES_MM) ** 2, axis=-1))
    grad = p / AXES_MM**2 / np.maximum(q, 1e-9)[..., None]
    norm = np.linalg.norm(grad, axis=-1)
    return (q - 1.0) / np.maximum(norm, 1e-12), grad / np.maximum(norm, 1e-12)[..., None]


def _slice_values(origin, row, col, normal, thickness) -> np.ndarray:
    """(ROWS, COLUMNS) HU of one slice: the fraction of each pixel's box (pixel x pixel x
    thickness) inside the ellipsoid, from its signed distance and the box's extent across
    the surface; 1000 HU inside, -1000 outside (0 HU is the unbiased threshold)."""
    i, j = np.meshgrid(np.arange(COLUMNS), np.arange(ROWS), indexing="xy")
    p = origin + (i[..., None] * row + j[..., None] * col) * PIXEL_MM
    s, g = _sdf(p)
    width = 0.5 * (np.abs(g @ row) * PIXEL_MM + np.abs(g @ col) * PIXEL_MM
                   + np.abs(g @ normal) * thickness)  # fmt: skip
    return -1000.0 + 2000.0 * np.clip(0.5 - s / (2.0 * width), 0.0, 1.0)


def write_tilted_series(folder: Path, steps_mm: list[float], tilt_deg: float) -> None:
    """A CT series as a tilted gantry writes it: slice planes turned by `tilt_deg` about the
    patient's x axis (ImageOrientationPatient rows along x, columns along y cos - z sin), their
    positions advancing along the table (z) so that they are `steps_mm` apart along their
    normal; each slice as thick as its wider neighbouring step."""
    folder.mkdir(parents=True, exist_ok=True)
    t = np.deg2rad(tilt_deg)
    row = np.array([1.0, 0.0, 0.0])
    col = np.array([0.0, np.cos(t), -np.sin(t)])
    normal = np.cross(row, col)
    heights = np.concatenate([[0.0], np.cumsum(steps_mm)])
    heights -= heights.mean()
    series = generate_uid()
    for k, w in enumerate(heights):
        # On the table's axis z, at height w along the normal; the image centred on the axis.
        centre = np.array([0.0, 0.0, w / normal[2]])
        origin = centre - (COLUMNS - 1) / 2 * PIXEL_MM * row - (ROWS - 1) / 2 * PIXEL_MM * col
        thickness = max(steps_mm[max(k - 1, 0)], steps_mm[min(k, len(steps_mm) - 1)])
        values = _slice_values(origin, row, col, normal, thickness)
        meta = FileMetaDataset()
        meta.MediaStorageSOPClassUID = CTImageStorage
        meta.MediaStorageSOPInstanceUID = generate_uid()
        meta.TransferSyntaxUID = ExplicitVRLittleEndian
        ds = pydicom.Dataset()
        ds.file_meta = meta
        ds.SOPClassUID, ds.SOPInstanceUID = CTImageStorage, meta.MediaStorageSOPInstanceUID
        ds.SeriesInstanceUID, ds.Modality = series, "CT"
        ds.Rows, ds.Columns = ROWS, COLUMNS
        ds.SamplesPerPixel, ds.PhotometricInterpretation = 1, "MONOCHROME2"
        ds.BitsAllocated, ds.BitsStored, ds.HighBit, ds.PixelRepresentation = 16, 16, 15, 1
        ds.ImagePositionPatient = [float(v) for v in origin]
        ds.ImageOrientationPatient = [float(v) for v in (*row, *col)]
        ds.PixelSpacing = [PIXEL_MM, PIXEL_MM]
        ds.SliceThickness = thickness
        ds.GantryDetectorTilt = tilt_deg
        ds.RescaleSlope, ds.RescaleIntercept = 1.0, -1024.0
        ds.PixelData = (np.round(values) + 1024).astype(np.int16).tobytes()
        # Files named out of order: the reader sorts by position.
        ds.save_as(folder / f"im{(k * 7) % len(heights):03d}.dcm", enforce_file_format=True)


def ellipsoid_points(n_u: int = 400, n_v: int = 800) -> np.ndarray:
    """Points on the ellipsoid [mm], at most about 0.25 mm apart."""
    u, v = np.meshgrid(np.linspace(0, np.pi, n_u), np.linspace(0, 2 * np.pi, n_v))
    p = np.stack([np.sin(u) * np.cos(v), np.sin(u) * np.sin(v), np.cos(u)], -1).reshape(-1, 3)
    return p * AXES_MM


def mesh_to_surface_mm(vertices_mm: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distances [mm] of the mesh's vertices from the ellipsoid (to its densely sampled
    surface: within 0.15 mm), and of the ellipsoid's points from the mesh (exact)."""
    surface = ellipsoid_points()
    out, _ = cKDTree(surface).query(vertices_mm)
    d2, _, _ = point_mesh_squared_distance(surface[::7], vertices_mm, faces)
    return out, np.sqrt(d2)


@pytest.mark.parametrize("tilt_deg", [0.0, 15.0, 30.0])
def test_mixed_steps_and_tilt_resampled_and_meshed_on_the_surface(
    tmp_path: Path, tilt_deg: float
) -> None:
    write_tilted_series(tmp_path / "ct", STEPS_MM, tilt_deg)
    volume = read_volume(tmp_path / "ct")
    r = volume.resampled
    assert r is not None and r.slices == len(STEPS_MM) + 1
    assert r.step_min_mm == pytest.approx(1.0, abs=1e-3)
    assert r.step_max_mm == pytest.approx(7.0, abs=1e-3)
    assert r.tilt_deg == pytest.approx(tilt_deg, abs=0.05)
    assert r.voxel_mm == pytest.approx((PIXEL_MM, PIXEL_MM, 1.0), abs=1e-4)
    assert str(r).startswith("resampled: slice steps 1.00-7.00 mm, tilt ")
    # A regular grid in the patient frame: orthogonal axes, the slices' normal as k.
    A = volume.affine_lps[:3, :3] / np.array(r.voxel_mm)
    np.testing.assert_allclose(A.T @ A, np.eye(3), atol=1e-9)
    bone = bone_model(volume, iso_hu=0.0, target_faces=30_000)
    out, cover = mesh_to_surface_mm(np.asarray(bone.mesh.vertices) * 1e3, bone.mesh.faces)
    third = max(STEPS_MM) / 3.0
    assert out.max() < third and cover.max() < third, (out.max(), cover.max())
    assert out.mean() < 0.1 * max(STEPS_MM)
    assert bone.check.watertight


def test_resampled_at_a_given_voxel_size(tmp_path: Path) -> None:
    """--voxel-mm: the grid at the size asked for; a regular series too."""
    write_tilted_series(tmp_path / "ct", [2.0] * 30, 0.0)
    regular = read_volume(tmp_path / "ct")
    assert regular.resampled is None  # even steps, no tilt: the file's own grid
    np.testing.assert_allclose(regular.spacing_mm, [PIXEL_MM, PIXEL_MM, 2.0])
    coarse = read_volume(tmp_path / "ct", voxel_size("1.5"))
    assert coarse.resampled is not None and coarse.resampled.voxel_mm == (1.5, 1.5, 1.5)
    np.testing.assert_allclose(coarse.spacing_mm, [1.5, 1.5, 1.5])
    # The same point of the ellipsoid's surface value (0 HU at the surface) on both grids.
    for volume in (regular, coarse):
        p = np.array([[AXES_MM[0], 0.0, 0.0]])
        value = ndimage.map_coordinates(volume.data, volume.lps_to_index(p).T, order=1)
        assert abs(float(value[0])) < 150.0  # within 0.15 mm of the ramp's zero
    with pytest.raises(VolumeError, match=r"voxel size '0\.01'"):
        voxel_size("0.01")


def test_nifti_with_a_sheared_slice_axis_is_resampled(tmp_path: Path) -> None:
    """A NIfTI that kept a 30 deg gantry tilt in its affine (the slice axis sheared off the
    normal): resampled onto the slices' own orthogonal frame, meshed on the ellipsoid."""
    tilt = np.deg2rad(30.0)
    step = 2.0
    row, col = np.array([1.0, 0.0, 0.0]), np.array([0.0, np.cos(tilt), -np.sin(tilt)])
    normal = np.cross(row, col)
    a_k = np.array([0.0, 0.0, step / normal[2]])  # along the table
    n_k = 36
    origin0 = -(COLUMNS - 1) / 2 * PIXEL_MM * row - (ROWS - 1) / 2 * PIXEL_MM * col
    origin0 = origin0 - (n_k - 1) / 2 * a_k
    data = np.stack(
        [_slice_values(origin0 + k * a_k, row, col, normal, step).T for k in range(n_k)], -1
    ).astype(np.float32)  # (i, j, k)
    affine_lps = np.eye(4)
    affine_lps[:3, 0], affine_lps[:3, 1] = row * PIXEL_MM, col * PIXEL_MM
    affine_lps[:3, 2], affine_lps[:3, 3] = a_k, origin0
    nib.save(nib.Nifti1Image(data, RAS_FROM_LPS @ affine_lps), str(tmp_path / "tilted.nii.gz"))
    volume = read_volume(tmp_path / "tilted.nii.gz")
    assert volume.native_frame == "RAS" and volume.resampled is not None
    assert volume.resampled.tilt_deg == pytest.approx(30.0, abs=0.05)
    bone = bone_model(volume, iso_hu=0.0, target_faces=30_000)
    out, cover = mesh_to_surface_mm(np.asarray(bone.mesh.vertices) * 1e3, bone.mesh.faces)
    assert out.max() < step / 3.0 and cover.max() < step / 3.0, (out.max(), cover.max())


def test_a_gap_of_missing_slices_is_refused_naming_it(tmp_path: Path, capsys) -> None:
    steps = [2.0] * 10 + [30.0] + [2.0] * 10
    write_tilted_series(tmp_path / "ct", steps, 15.0)
    with pytest.raises(VolumeError, match=r"slice gap of 30\.0 mm between im\d+\.dcm and "
                       r"im\d+\.dcm \(20\.0 to 50\.0 mm along"):  # fmt: skip
        read_volume(tmp_path / "ct")
    assert read_volume(tmp_path / "ct", max_gap_mm=31.0).resampled is not None
    out = tmp_path / "bone.stl"
    assert main(["model", str(tmp_path / "ct"), "--iso", "0", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "slice gap of 30.0 mm" in err and len(err.splitlines()) == 1
    assert not out.exists()


def test_cli_says_how_it_resampled(tmp_path: Path, capsys) -> None:
    write_tilted_series(tmp_path / "ct", STEPS_MM, 15.0)
    assert main(["model", str(tmp_path / "ct"), "--iso", "0"]) == 0
    text = capsys.readouterr().out
    said = "resampled: slice steps 1.00-7.00 mm, tilt 15.0 deg -> regular 0.80 x 0.80 x 1.00"
    assert said in text


def test_a_jobs_object_from_an_irregular_series_says_how_it_was_resampled(tmp_path: Path) -> None:
    """The job's virtual model of a CT series (`cell.object.model`): resampled at
    `model.ct.resample_mm`, and its source says so."""
    from scenarios.configuration.cell_sections import CTSection
    from scenarios.offline.operations import virtual_model

    write_tilted_series(tmp_path / "ct", STEPS_MM, 15.0)
    section = CTSection.model_validate({"iso_hu": 0.0, "resample_mm": "1x1x1.5"})
    model = virtual_model(str(tmp_path / "ct"), "mm", None, "touch", 0, section.iso_hu,
                          section.resample_mm, section.max_gap_mm)  # fmt: skip
    assert "resampled: slice steps 1.00-7.00 mm, tilt 15.0 deg -> regular 1.00 x 1.00 x 1.50" in (
        model.source
    )
    extent_mm = np.ptp(np.asarray(model.mesh.vertices), axis=0) * 1e3
    np.testing.assert_allclose(extent_mm, 2 * AXES_MM, atol=max(STEPS_MM) / 3.0)


def test_nifti_stacked_against_the_normal_resampled_in_place(tmp_path: Path) -> None:
    """A NIfTI whose slice axis runs against the slices' normal (k down the patient), asked
    for 1 mm voxels: the bright block lands where the file put it (its centroid to 0.25 mm)."""
    data = np.full((20, 16, 10), -1000.0, dtype=np.float32)
    data[5:9, 4:8, 2:5] = 1000.0
    affine_lps = np.diag([0.8, 0.9, -2.0, 1.0])
    affine_lps[:3, 3] = [-5.0, 3.0, 40.0]
    nib.save(nib.Nifti1Image(data, RAS_FROM_LPS @ affine_lps), str(tmp_path / "down.nii"))

    def centroid(volume) -> np.ndarray:
        ijk = np.argwhere(volume.data > 0.0)
        w = volume.data[volume.data > 0.0]
        return (volume.index_to_lps(ijk) * w[:, None]).sum(0) / w.sum()

    kept = read_volume(tmp_path / "down.nii")
    assert kept.resampled is None
    fine = read_volume(tmp_path / "down.nii", voxel_size(1.0))
    assert fine.resampled is not None and np.linalg.det(fine.affine_lps[:3, :3]) > 0
    np.testing.assert_allclose(centroid(fine), centroid(kept), atol=0.25)
