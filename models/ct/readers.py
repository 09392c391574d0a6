"""Volume files: a DICOM series (pydicom), NIfTI (nibabel) and NRRD (pynrrd), each with its
voxel spacing, slice positions and orientation, read into a `Volume` (volume.py for the
frames). Anything that is not a usable volume is refused with one line naming the file."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from models.ct.volume import RAS_FROM_LPS, Volume, VolumeError

NIFTI_SUFFIXES = (".nii", ".nii.gz")
NRRD_SUFFIXES = (".nrrd", ".nhdr")
#: Slice positions may differ from even spacing by this fraction of the spacing.
SPACING_TOLERANCE = 0.01


def is_volume(path: str | Path) -> bool:
    """Whether `path` names a volume (a folder, a NIfTI, NRRD or DICOM file) rather than a
    mesh or a built-in model."""
    p = Path(path)
    name = p.name.lower()
    return p.is_dir() or name.endswith((*NIFTI_SUFFIXES, *NRRD_SUFFIXES, ".dcm"))


def read_volume(path: str | Path) -> Volume:
    """A volume from a DICOM series folder (or one of its files), a NIfTI or an NRRD file."""
    path = Path(path)
    if not path.exists():
        raise VolumeError(f"{path}: no such file or folder")
    name = path.name.lower()
    if path.is_dir():
        return read_dicom_series(path)
    if name.endswith(NIFTI_SUFFIXES):
        return read_nifti(path)
    if name.endswith(NRRD_SUFFIXES):
        return read_nrrd(path)
    return read_dicom_series(path.parent, only=path)


def read_nifti(path: Path) -> Volume:
    import nibabel as nib

    try:
        image = nib.load(str(path))
        data = np.asarray(image.get_fdata(dtype=np.float32))
    except Exception as exc:  # nibabel raises many kinds for a bad file
        raise VolumeError(f"{path}: not a NIfTI volume ({exc})") from None
    if data.ndim == 4 and data.shape[3] == 1:
        data = data[..., 0]
    if data.ndim != 3:
        raise VolumeError(f"{path}: a 3D volume is needed, this one has shape {data.shape}")
    return Volume(data, RAS_FROM_LPS @ np.asarray(image.affine, float), None, "RAS", str(path))


def read_nrrd(path: Path) -> Volume:
    import nrrd

    try:
        data, header = nrrd.read(str(path))
    except Exception as exc:  # pynrrd raises NRRDError and others
        raise VolumeError(f"{path}: not an NRRD volume ({exc})") from None
    if data.ndim != 3:
        raise VolumeError(f"{path}: a 3D volume is needed, this one has shape {data.shape}")
    space = str(header.get("space", "")).lower()
    frames = {"left-posterior-superior": "LPS", "right-anterior-superior": "RAS"}
    if space not in frames or "space directions" not in header:
        raise VolumeError(
            f"{path}: NRRD space {space or 'missing'!r}: needs 'space directions' in one of "
            f"{list(frames)}"
        )
    directions = np.asarray(header["space directions"], dtype=float)  # rows: axes
    origin = np.asarray(header.get("space origin", np.zeros(3)), dtype=float)
    affine = np.eye(4)
    affine[:3, :3], affine[:3, 3] = directions.T, origin
    if frames[space] == "RAS":
        affine = RAS_FROM_LPS @ affine
    return Volume(data.astype(np.float32), affine, None, frames[space], str(path))


def read_dicom_series(folder: Path, only: Path | None = None) -> Volume:
    """A CT/MR series from `folder`: the series of the file `only`, or the folder's one
    series (a folder holding several must be given one file of the series wanted): slices
    sorted along their normal, evenly spaced, one orientation."""
    import warnings

    import pydicom

    headers: dict[str, list[tuple[Path, object]]] = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # pydicom warns on the VR quirks it reads through
        for f in sorted(p for p in folder.iterdir() if p.is_file()):
            try:
                ds = pydicom.dcmread(f, stop_before_pixels=True)
            except Exception:
                if only is not None and f == only:
                    raise VolumeError(f"{only}: not a volume (NIfTI, NRRD or DICOM)") from None
                continue
            if "Rows" in ds and "Columns" in ds:
                headers.setdefault(str(ds.get("SeriesInstanceUID", "?")), []).append((f, ds))
    where = only or folder
    if not headers:
        raise VolumeError(f"{where}: no DICOM image in {folder}")
    if only is not None:
        series = next((k for k, v in headers.items() if any(f == only for f, _ in v)), None)
        if series is None:
            raise VolumeError(f"{only}: a DICOM file without an image")
    elif len(headers) == 1:
        series = next(iter(headers))
    else:
        listed = "; ".join(
            f"{v[0][1].get('Modality', '?')} {len(v)} slice(s) ({v[0][0].name})"  # type: ignore[attr-defined]
            for v in headers.values()
        )
        raise VolumeError(
            f"{folder}: {len(headers)} series ({listed}): give one file of the series wanted"
        )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        slices = [(f, pydicom.dcmread(f)) for f, _ in headers[series]]
    for f, ds in slices:
        for tag in ("ImagePositionPatient", "ImageOrientationPatient", "PixelSpacing"):
            if tag not in ds:
                raise VolumeError(f"{f}: DICOM slice without {tag}: no patient frame")
    orientation = np.array([float(v) for v in slices[0][1].ImageOrientationPatient])
    for f, ds in slices[1:]:
        if (
            np.abs(np.array([float(v) for v in ds.ImageOrientationPatient]) - orientation).max()
            > 1e-4
        ):
            raise VolumeError(f"{where}: mixed slice orientations ({slices[0][0].name}, {f.name})")
    row, col = orientation[:3], orientation[3:]
    normal = np.cross(row, col)
    positions = np.array([[float(v) for v in ds.ImagePositionPatient] for _, ds in slices])
    order = np.argsort(positions @ normal)
    slices = [slices[k] for k in order]
    positions = positions[order]
    steps = np.diff(positions @ normal)
    if len(slices) < 2:
        raise VolumeError(f"{where}: one slice is no volume")
    spacing = float(np.median(steps))
    if spacing <= 0 or np.abs(steps - spacing).max() > SPACING_TOLERANCE * spacing:
        gaps = np.flatnonzero(np.abs(steps - spacing) > SPACING_TOLERANCE * spacing)
        kind = "gaps" if spacing > 0 and np.all(steps[gaps] > spacing) else "inconsistent spacing"
        raise VolumeError(
            f"{where}: slice {kind}: steps {np.round(steps[gaps][:3], 3).tolist()} mm against "
            f"{spacing:.3f} mm (at slices {gaps[:3].tolist()})"
        )
    shapes = {(int(ds.Rows), int(ds.Columns)) for _, ds in slices}
    if len(shapes) != 1:
        raise VolumeError(f"{where}: slices of different sizes {sorted(shapes)}")
    pixel = [float(v) for v in slices[0][1].PixelSpacing]  # between rows, between columns
    data = np.stack(
        [
            ds.pixel_array.astype(np.float32) * float(getattr(ds, "RescaleSlope", 1.0))
            + float(getattr(ds, "RescaleIntercept", 0.0))
            for _, ds in slices
        ],
        axis=-1,
    )  # (rows j, columns i, k)
    data = np.transpose(data, (1, 0, 2))  # (i, j, k)
    affine = np.eye(4)
    affine[:3, 0] = row * pixel[1]
    affine[:3, 1] = col * pixel[0]
    # The slices' own step, which a tilted gantry shears off the normal.
    affine[:3, 2] = (positions[-1] - positions[0]) / (len(slices) - 1)
    affine[:3, 3] = positions[0]
    modality = str(getattr(slices[0][1], "Modality", "")) or None
    return Volume(data, affine, modality, "LPS", str(where))
