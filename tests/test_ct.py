"""CT volumes to bone models: the readers' patient frames against hand-computed points, the
bone surface of generated volumes against their analytic surfaces, a simulated CT of the
skull phantom against the phantom, and each bad input refused with one line."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import nibabel as nib
import nrrd
import numpy as np
import pydicom
import pytest
from pydicom.dataset import FileMetaDataset
from pydicom.uid import CTImageStorage, ExplicitVRLittleEndian, generate_uid

from models.ct import CTSettings, VolumeError, bone_model, ct_scan, read_plan, read_volume
from models.ct.volume import Volume
from models.registry import builtin_model
from registration import MeshModel
from scenarios.cli.app import main


def _dataset(sop_class: str, series: str, modality: str, rows: int, columns: int) -> Any:
    """A DICOM image dataset of `sop_class` with 16-bit signed monochrome pixels."""
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID = sop_class
    meta.MediaStorageSOPInstanceUID = generate_uid()
    meta.TransferSyntaxUID = ExplicitVRLittleEndian
    ds = pydicom.Dataset()
    ds.file_meta = meta
    ds.SOPClassUID, ds.SOPInstanceUID = sop_class, meta.MediaStorageSOPInstanceUID
    ds.SeriesInstanceUID, ds.Modality = series, modality
    ds.Rows, ds.Columns = rows, columns
    ds.SamplesPerPixel, ds.PhotometricInterpretation = 1, "MONOCHROME2"
    ds.BitsAllocated, ds.BitsStored, ds.HighBit, ds.PixelRepresentation = 16, 16, 15, 1
    return ds


def _write_dicom(folder: Path, data: np.ndarray, z_mm: list[float], pixel=(0.6, 0.5),
                 modality="CT", orientations=None) -> None:  # fmt: skip
    """One file per slice k of data (I, J, K) HU: rows = j, columns = i."""
    folder.mkdir(parents=True, exist_ok=True)
    series = generate_uid()
    for k, z in enumerate(z_mm):
        ds = _dataset(CTImageStorage, series, modality, data.shape[1], data.shape[0])
        ds.ImagePositionPatient = [-100.0, -120.0, float(z)]
        iop = [1, 0, 0, 0, 1, 0] if orientations is None else orientations[k]
        ds.ImageOrientationPatient = [float(v) for v in iop]
        ds.PixelSpacing = [pixel[0], pixel[1]]
        ds.RescaleSlope, ds.RescaleIntercept = 1.0, -1024.0
        ds.PixelData = (data[:, :, k].T + 1024).astype(np.int16).tobytes()
        ds.save_as(folder / f"slice{k:03d}.dcm", enforce_file_format=True)


def _ball(shape=(40, 40, 30), spacing=(1.0, 1.0, 1.0), radius=10.0, hollow=0.0) -> Volume:
    """A ball (or a shell with a closed void of radius `hollow`) centred in the grid, with
    exact partial volume from its analytic distance (no blur, no noise): 1000 HU in it, -1000
    outside, so that 0 HU is the unbiased threshold."""
    spacing = np.asarray(spacing)
    centre = (np.asarray(shape) - 1) * spacing / 2
    ijk = np.stack(np.meshgrid(*[np.arange(n) for n in shape], indexing="ij"), -1)
    r = np.linalg.norm(ijk * spacing - centre, axis=-1)
    sdf = r - radius if hollow == 0 else np.maximum(r - radius, hollow - r)
    normal = (ijk * spacing - centre) / np.maximum(r, 1e-9)[..., None]
    width = 0.5 * np.abs(normal) @ spacing
    fraction = np.clip(0.5 - sdf / (2 * width), 0.0, 1.0)
    affine = np.eye(4)
    affine[:3, :3] = np.diag(spacing)
    return Volume(-1000.0 + 2000.0 * fraction, affine, "CT", "LPS", "generated ball")


# -- frames --------------------------------------------------------------------------------
def test_dicom_series_frame_by_hand(tmp_path: Path) -> None:
    """Voxel (i, j, k) = (2, 3, 1) of a series at IPP (-100, -120, z), columns along x at
    0.5 mm, rows along y at 0.6 mm, slices 1.25 mm apart: LPS (-99, -118.2, z0 + 1.25)."""
    data = np.zeros((8, 6, 4))
    data[2, 3, 1] = 700.0
    _write_dicom(tmp_path / "s", data, [10.0, 11.25, 12.5, 13.75])
    volume = read_volume(tmp_path / "s")
    assert volume.data.shape == (8, 6, 4) and volume.native_frame == "LPS"
    assert volume.data[2, 3, 1] == pytest.approx(700.0)
    np.testing.assert_allclose(volume.index_to_lps([[2, 3, 1]]), [[-99.0, -118.2, 11.25]])
    np.testing.assert_allclose(volume.spacing_mm, [0.5, 0.6, 1.25])


def test_nifti_ras_and_nrrd_frames_by_hand(tmp_path: Path) -> None:
    """A NIfTI affine maps (1, 2, 3) to RAS (10.5, -20 + 1.6, 30 + 7.5) = LPS (-10.5, 18.4,
    37.5); an NRRD in RAS the same; an NRRD in LPS maps straight."""
    affine = np.array([[0.5, 0, 0, 10.0], [0, 0.8, 0, -20.0], [0, 0, 2.5, 30.0], [0, 0, 0, 1]])
    data = np.arange(4 * 5 * 6, dtype=np.float32).reshape(4, 5, 6)
    nib.save(nib.Nifti1Image(data, affine), str(tmp_path / "v.nii.gz"))
    expected = np.array([[-10.5, 18.4, 37.5]])
    nifti = read_volume(tmp_path / "v.nii.gz")
    assert nifti.native_frame == "RAS" and nifti.modality is None
    np.testing.assert_allclose(nifti.index_to_lps([[1, 2, 3]]), expected)
    assert nifti.data[1, 2, 3] == data[1, 2, 3]
    header = {"space": "right-anterior-superior", "space directions": affine[:3, :3].T,
              "space origin": affine[:3, 3]}  # fmt: skip
    nrrd.write(str(tmp_path / "ras.nrrd"), data, header)
    np.testing.assert_allclose(read_volume(tmp_path / "ras.nrrd").index_to_lps([[1, 2, 3]]),
                               expected)  # fmt: skip
    header["space"] = "left-posterior-superior"
    nrrd.write(str(tmp_path / "lps.nrrd"), data, header)
    np.testing.assert_allclose(read_volume(tmp_path / "lps.nrrd").index_to_lps([[1, 2, 3]]),
                               [[10.5, -18.4, 37.5]])  # fmt: skip


# -- bone surfaces ------------------------------------------------------------------------------
@pytest.mark.parametrize("spacing", [(1.0, 1.0, 1.0), (0.5, 0.5, 1.0)])
def test_ball_surface_within_a_fraction_of_a_voxel(spacing: tuple[float, float, float]) -> None:
    """The mesh of a ball lies within 0.15 of the largest voxel side of the sphere (mean
    within 0.05): marching cubes on a linear partial-volume ramp, then smoothing and
    decimation; watertight, its volume within 1 % of 4/3 pi r^3."""
    shape = tuple(round(40 / s) for s in spacing)
    volume = _ball(shape, spacing, radius=12.0)
    bone = bone_model(volume, iso_hu=0.0, target_faces=20_000)
    centre = (np.asarray(shape) - 1) * np.asarray(spacing) / 2
    r = np.linalg.norm(np.asarray(bone.mesh.vertices) * 1e3 - centre, axis=1)
    error = np.abs(r - 12.0)
    h = max(spacing)
    assert error.max() < 0.15 * h and error.mean() < 0.05 * h
    assert bone.check.watertight and bone.check.deviation_max_m < 0.15 * h * 1e-3
    assert bone.check.volume_m3 == pytest.approx(4 / 3 * np.pi * 0.012**3, rel=0.01)


def test_shell_cavity_is_closed() -> None:
    """A shell around a closed void: the void is filled, only the outer sphere is meshed."""
    volume = _ball((40, 40, 40), (1.0, 1.0, 1.0), radius=14.0, hollow=9.0)
    bone = bone_model(volume, iso_hu=0.0, target_faces=20_000)
    r = np.linalg.norm(np.asarray(bone.mesh.vertices) * 1e3 - 19.5, axis=1)
    assert r.min() > 13.5  # no vertex on the void's surface (radius 9)


@pytest.mark.slow
def test_simulated_ct_of_the_phantom_errs_like_a_ct() -> None:
    """The skull phantom CT-scanned (0.5 x 0.5 x 1 mm, 0.7 mm blur, 20 HU noise, 300 HU
    threshold): the bone model lies 0.05-0.3 mm from the phantom on average (the threshold's
    bias through the blur; not zero, as a perfect copy would) and within 1 mm everywhere."""
    skull = builtin_model("skull")
    volume = ct_scan(skull.mesh, CTSettings(), np.random.default_rng(0))
    bone = bone_model(volume, iso_hu=300.0)
    shape = MeshModel(np.asarray(skull.mesh.vertices), np.asarray(skull.mesh.faces))
    d = shape.closest(np.asarray(bone.mesh.vertices)).distances
    assert 0.05e-3 < d.mean() < 0.3e-3 and d.max() < 1e-3
    assert bone.check.watertight


# -- bad input ----------------------------------------------------------------------------------
def test_a_file_that_is_not_a_volume(tmp_path: Path) -> None:
    bad = tmp_path / "scan.nii"
    bad.write_text("not a volume")
    with pytest.raises(VolumeError, match=r"scan\.nii: not a NIfTI volume"):
        read_volume(bad)


@pytest.mark.parametrize(
    ("z", "orientations", "match"),
    [
        ([0.0, 1.0, 2.0, 32.0], None, r"slice gap of 30\.0 mm between slice002\.dcm and "
         r"slice003\.dcm"),
        ([0.0, 1.0, 1.0, 2.0], None, r"two slices at the same position \(slice001\.dcm"),
        ([0.0, 1.0, 2.0, 3.0], [[1, 0, 0, 0, 1, 0]] * 3 + [[1, 0, 0, 0, 0.8, 0.6]],
         "mixed slice orientations"),
    ],
)  # fmt: skip
def test_bad_dicom_series(tmp_path: Path, z: list[float], orientations, match: str) -> None:
    _write_dicom(tmp_path / "s", np.zeros((6, 6, 4)), z, orientations=orientations)
    with pytest.raises(VolumeError, match=match):
        read_volume(tmp_path / "s")


def test_dicom_slice_without_its_position(tmp_path: Path) -> None:
    _write_dicom(tmp_path / "s", np.zeros((6, 6, 3)), [0.0, 1.0, 2.0])
    ds = pydicom.dcmread(tmp_path / "s" / "slice001.dcm")
    del ds.ImagePositionPatient
    ds.save_as(tmp_path / "s" / "slice001.dcm")
    with pytest.raises(VolumeError, match=r"slice001\.dcm: DICOM slice without ImagePosition"):
        read_volume(tmp_path / "s")


def test_threshold_on_mr_and_thresholds_that_select_nothing_or_everything(tmp_path: Path) -> None:
    data = np.full((8, 8, 4), -500.0)
    data[2:6, 2:6, 1:3] = 800.0
    _write_dicom(tmp_path / "mr", data, [0.0, 1.0, 2.0, 3.0], modality="MR")
    with pytest.raises(VolumeError, match="modality MR, not CT"):
        bone_model(read_volume(tmp_path / "mr"))
    ct = _ball((20, 20, 20))
    with pytest.raises(VolumeError, match="selects nothing"):
        bone_model(ct, iso_hu=1500.0)
    with pytest.raises(VolumeError, match="selects everything"):
        bone_model(ct, iso_hu=-2000.0)


def test_plan_in_the_volume_frame(tmp_path: Path) -> None:
    """A plan in the volume's frame becomes burr holes in the model frame (m); outside the
    volume, or in the other frame, it is refused."""
    volume = _ball((40, 40, 30))
    plan = {"frame": "LPS", "targets": [{"name": "a", "entry": [19.5, 19.5, 26.0],
                                          "target": [19.5, 19.5, 16.0]}]}  # fmt: skip
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(plan))
    (hole,) = read_plan(path, volume)
    np.testing.assert_allclose(hole.p_entry, [0.0195, 0.0195, 0.026])
    np.testing.assert_allclose(hole.direction, [0.0, 0.0, -1.0])
    assert hole.depth == pytest.approx(0.010)
    plan["targets"][0]["entry"] = [19.5, 19.5, 60.0]
    path.write_text(json.dumps(plan))
    with pytest.raises(VolumeError, match=r"entry .* outside the volume"):
        read_plan(path, volume)
    plan["frame"] = "RAS"
    path.write_text(json.dumps(plan))
    with pytest.raises(VolumeError, match="the plan is in 'RAS'"):
        read_plan(path, volume)


def test_cli_meshes_a_volume_and_refuses_a_bad_one(tmp_path: Path, capsys) -> None:
    data = np.full((24, 24, 20), -1000.0)
    data[6:18, 6:18, 5:15] = 1200.0
    _write_dicom(tmp_path / "ct", data, [float(z) for z in range(20)])
    out = tmp_path / "bone.stl"
    assert main(["model", str(tmp_path / "ct"), "--iso", "300", "--out", str(out)]) == 0
    assert out.is_file() and "watertight" in capsys.readouterr().out
    bad = tmp_path / "x.nrrd"
    bad.write_text("nope")
    assert main(["model", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "x.nrrd: not an NRRD volume" in err and len(err.strip().splitlines()) == 1


def test_files_left_out_of_a_series_are_named_and_counted(tmp_path: Path, capsys) -> None:
    """A series folder of 20 slices, a file that is no DICOM, one cut in its header (DICOM
    without an image) and a notes file: the volume is the 20 slices, and the 3 files left out
    are named with why in the volume, in the model's source and by `twincell model`."""
    from models.ct.object import volume_object

    data = np.full((24, 24, 20), -1000.0)
    data[6:18, 6:18, 5:15] = 1200.0
    folder = tmp_path / "ct"
    _write_dicom(folder, data, [float(z) for z in range(20)])
    (folder / "broken.dcm").write_bytes(b"\0" * 64 + b"not a DICOM file")
    (folder / "cut.dcm").write_bytes((folder / "slice003.dcm").read_bytes()[:200])
    (folder / "notes.txt").write_text("scanned on Tuesday")
    volume = read_volume(folder)
    assert volume.data.shape == (24, 24, 20)
    assert volume.skipped is not None
    assert volume.skipped.total == 23
    assert volume.skipped.files == (
        ("broken.dcm", "not DICOM"),
        ("cut.dcm", "DICOM without an image"),
        ("notes.txt", "not DICOM"),
    )
    line = (
        f"3 of 23 files in {folder} skipped: broken.dcm (not DICOM), cut.dcm (DICOM without "
        f"an image), notes.txt (not DICOM)"
    )
    assert str(volume.skipped) == line
    assert line in volume_object(folder).source
    assert main(["model", str(folder)]) == 0
    out, err = capsys.readouterr()
    assert err == f"twincell: warning: {line}\n"
    assert "files skipped" in out and "broken.dcm" in out
    # A clean series skips nothing; a folder of nothing readable says what it left out.
    for name in ("broken.dcm", "cut.dcm", "notes.txt"):
        (folder / name).rename(tmp_path / name)
    assert read_volume(folder).skipped is None
    empty = tmp_path / "empty"
    empty.mkdir()
    (tmp_path / "broken.dcm").rename(empty / "broken.dcm")
    with pytest.raises(VolumeError, match=r"no DICOM image in .*empty \(1 of 1 files in "
                       r".*empty skipped: broken\.dcm \(not DICOM\)\)"):  # fmt: skip
        read_volume(empty)


def test_many_files_left_out_are_all_counted() -> None:
    """The one-line form names the first ten files left out and counts the rest."""
    from models.ct.volume import SkippedFiles

    skipped = SkippedFiles("ct", 120, tuple((f"x{k}.dcm", "not DICOM") for k in range(12)))
    text = str(skipped)
    assert text.startswith("12 of 120 files in ct skipped: x0.dcm (not DICOM), ")
    assert "x9.dcm (not DICOM), and 2 more" in text and "x10.dcm" not in text


def test_box_with_a_through_hole() -> None:
    """A 40 x 30 x 20 mm box drilled through by a 10 mm hole, CT-scanned at 0.5 x 0.5 x 1
    mm without noise and segmented at the midpoint threshold: the hole stays open (it is no
    cavity) and its wall lies within 0.3 of the slice thickness of radius 5 mm; the top face
    within the same of z = 10 mm."""
    import manifold3d

    from models.mesh import TriangleMesh

    box = manifold3d.Manifold.cube((40.0, 30.0, 20.0), center=True)
    hole = manifold3d.Manifold.cylinder(40.0, 5.0, 5.0, 128, center=True)
    solid = (box - hole).to_mesh()
    mesh = TriangleMesh(np.asarray(solid.vert_properties)[:, :3] * 1e-3, solid.tri_verts)
    settings = CTSettings(noise_hu=0.0, iso_hu=100.0)
    volume = ct_scan(mesh, settings, np.random.default_rng(0))
    bone = bone_model(volume, iso_hu=100.0, target_faces=30_000)
    p = np.asarray(bone.mesh.vertices) * 1e3
    r = np.hypot(p[:, 0], p[:, 1])
    wall = (r < 8.0) & (np.abs(p[:, 2]) < 7.0)
    assert wall.sum() > 50 and np.abs(r[wall] - 5.0).max() < 0.3
    top = (np.abs(p[:, 0]) < 15.0) & (np.abs(p[:, 1]) < 10.0) & (r > 8.0) & (p[:, 2] > 5.0)
    assert np.abs(p[top, 2] - 10.0).max() < 0.3
    assert bone.check.watertight


def test_a_folder_of_two_series(tmp_path: Path) -> None:
    """A folder holding a CT series and a one-slice scout: the folder is refused naming
    both; one file of the CT series picks it."""
    _write_dicom(tmp_path / "s", np.zeros((6, 6, 3)), [0.0, 1.0, 2.0])
    _write_dicom(tmp_path / "scout", np.zeros((6, 6, 1)), [0.0])
    (tmp_path / "scout" / "slice000.dcm").rename(tmp_path / "s" / "scout.dcm")
    with pytest.raises(VolumeError, match=r"2 series .* give one file of the series wanted"):
        read_volume(tmp_path / "s")
    assert read_volume(tmp_path / "s" / "slice001.dcm").data.shape == (6, 6, 3)


def test_enhanced_multiframe_ct_frame_by_hand(tmp_path: Path) -> None:
    """An enhanced (multi-frame) CT in one file: frames stored out of order, positions per
    frame, orientation and spacing shared, rescale per frame. Voxel (2, 3, 1) -> LPS (-99,
    -118.2, 11.25) as for the classic series, its value rescaled."""
    from pydicom.sequence import Sequence
    from pydicom.uid import EnhancedCTImageStorage

    data = np.zeros((8, 6, 4))
    data[2, 3, 1] = 700.0
    ds = _dataset(EnhancedCTImageStorage, generate_uid(), "CT", 6, 8)
    ds.NumberOfFrames = 4
    shared = pydicom.Dataset()
    orientation, measures = pydicom.Dataset(), pydicom.Dataset()
    orientation.ImageOrientationPatient = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
    measures.PixelSpacing, measures.SliceThickness = [0.6, 0.5], 1.25
    shared.PlaneOrientationSequence = Sequence([orientation])
    shared.PixelMeasuresSequence = Sequence([measures])
    ds.SharedFunctionalGroupsSequence = Sequence([shared])
    order = [2, 0, 3, 1]  # frames out of order
    frames = []
    for k in order:
        group, plane, rescale = pydicom.Dataset(), pydicom.Dataset(), pydicom.Dataset()
        plane.ImagePositionPatient = [-100.0, -120.0, 10.0 + 1.25 * k]
        rescale.RescaleSlope, rescale.RescaleIntercept = 2.0, -1024.0
        group.PlanePositionSequence = Sequence([plane])
        group.PixelValueTransformationSequence = Sequence([rescale])
        frames.append(group)
    ds.PerFrameFunctionalGroupsSequence = Sequence(frames)
    stored = np.stack([(data[:, :, k].T + 1024.0) / 2.0 for k in order]).astype(np.int16)
    ds.PixelData = stored.tobytes()
    (tmp_path / "mf").mkdir()
    ds.save_as(tmp_path / "mf" / "enhanced.dcm", enforce_file_format=True)
    volume = read_volume(tmp_path / "mf" / "enhanced.dcm")
    assert volume.data.shape == (8, 6, 4) and volume.modality == "CT"
    assert volume.data[2, 3, 1] == pytest.approx(700.0)
    np.testing.assert_allclose(volume.index_to_lps([[2, 3, 1]]), [[-99.0, -118.2, 11.25]])


@pytest.mark.parametrize(
    "compressed",
    ["MR_small_jp2klossless.dcm", "MR_small_jpeg_ls_lossless.dcm", "MR_small_RLE.dcm"],
)
def test_compressed_series_decode_like_the_uncompressed(tmp_path: Path, compressed: str) -> None:
    """pydicom's shipped MR image in JPEG 2000, JPEG-LS and RLE, made into 3-slice series
    (positions 2 mm apart): the volume's voxels are the uncompressed twin's pixels."""
    from pydicom.data import get_testdata_file

    reference = pydicom.dcmread(get_testdata_file("MR_small.dcm")).pixel_array
    source = pydicom.dcmread(get_testdata_file(compressed))
    slope = float(source.get("RescaleSlope", 1.0))
    intercept = float(source.get("RescaleIntercept", 0.0))
    (tmp_path / "s").mkdir()
    for k in range(3):
        source.ImagePositionPatient = [0.0, 0.0, 2.0 * k]
        source.ImageOrientationPatient = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        source.SOPInstanceUID = generate_uid()
        source.save_as(tmp_path / "s" / f"{k}.dcm")
    volume = read_volume(tmp_path / "s")
    assert volume.data.shape == (64, 64, 3) and volume.modality == "MR"
    np.testing.assert_allclose(volume.data[:, :, 1], reference.T * slope + intercept)
    np.testing.assert_allclose(volume.spacing_mm[2], 2.0)
