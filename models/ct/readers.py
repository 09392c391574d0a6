"""Volume files: a DICOM series (pydicom), NIfTI (nibabel) and NRRD (pynrrd), each with its
voxel spacing, slice positions and orientation, read into a `Volume` (volume.py for the
frames). A series whose slices do not form a regular grid (uneven steps, a gantry tilt) is
resampled onto one (models.ct.regular), as is any volume asked for at a given voxel size.
Anything that is not a usable volume is refused with one line naming the file; a file of a
series folder that is left out (not DICOM, unreadable, no image) is named in the volume's
`skipped`."""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from models.ct.regular import MAX_GAP_MM, SliceStack, check_steps, is_regular, regularize, resample
from models.ct.volume import RAS_FROM_LPS, SkippedFiles, Volume, VolumeError

NIFTI_SUFFIXES = (".nii", ".nii.gz")
NRRD_SUFFIXES = (".nrrd", ".nhdr")


def is_volume(path: str | Path) -> bool:
    """Whether `path` names a volume (a folder, a NIfTI, NRRD or DICOM file) rather than a
    mesh or a built-in model."""
    p = Path(path)
    name = p.name.lower()
    return p.is_dir() or name.endswith((*NIFTI_SUFFIXES, *NRRD_SUFFIXES, ".dcm"))


def read_volume(
    path: str | Path,
    voxel_mm: tuple[float, float, float] | None = None,
    max_gap_mm: float = MAX_GAP_MM,
) -> Volume:
    """A volume from a DICOM series folder (or one of its files), a NIfTI or an NRRD file, on
    a regular grid: the file's own if it is one, else resampled at the pixel spacing and the
    smallest slice step, or at `voxel_mm` (i, j, k) [mm] if given (`Volume.resampled` says
    how). A step between slices wider than `max_gap_mm` [mm] is refused."""
    path = Path(path)
    if not path.exists():
        raise VolumeError(f"{path}: no such file or folder")
    name = path.name.lower()
    if path.is_dir():
        return read_dicom_series(path, voxel_mm=voxel_mm, max_gap_mm=max_gap_mm)
    if name.endswith(NIFTI_SUFFIXES):
        return regularize(read_nifti(path), voxel_mm, max_gap_mm)
    if name.endswith(NRRD_SUFFIXES):
        return regularize(read_nrrd(path), voxel_mm, max_gap_mm)
    return read_dicom_series(path.parent, only=path, voxel_mm=voxel_mm, max_gap_mm=max_gap_mm)


def read_nifti(path: Path) -> Volume:
    import nibabel as nib

    try:
        image: Any = nib.load(str(path))  # a NIfTI image (nibabel types it as any file)
        data = np.asarray(image.get_fdata(dtype=np.float32))
    except Exception as exc:  # nibabel raises many kinds for a bad file
        raise VolumeError(f"{path}: not a NIfTI volume ({exc})") from None
    if data.ndim == 4 and data.shape[3] == 1:
        data = data[..., 0]
    if data.ndim != 3:
        raise VolumeError(f"{path}: a 3D volume is needed, this one has shape {data.shape}")
    affine = RAS_FROM_LPS @ np.asarray(image.affine, dtype=float)
    return Volume(data, affine, None, "RAS", str(path))


def read_nrrd(path: Path) -> Volume:
    import nrrd

    try:
        data, header = nrrd.read(str(path))
    except Exception as exc:  # pynrrd raises NRRDError and others
        raise VolumeError(f"{path}: not an NRRD volume ({exc})") from None
    if data.ndim != 3:
        raise VolumeError(f"{path}: a 3D volume is needed, this one has shape {data.shape}")
    space = str(header.get("space", "")).lower()
    frames = {"left-posterior-superior": "LPS", "right-anterior-superior": "RAS", "lps": "LPS",
              "ras": "RAS"}  # fmt: skip
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


def read_dicom_series(
    folder: Path,
    only: Path | None = None,
    voxel_mm: tuple[float, float, float] | None = None,
    max_gap_mm: float = MAX_GAP_MM,
) -> Volume:
    """A CT/MR series from `folder`: the series of the file `only`, or the folder's one
    series (a folder holding several must be given one file of the series wanted): slices
    of one orientation sorted along their normal, resampled onto a regular grid if their
    steps vary or they are tilted (or at `voxel_mm`, if given); a gap wider than
    `max_gap_mm` [mm] is refused. The folder's files left out are the volume's `skipped`."""
    import warnings

    import pydicom

    headers, skipped = _series_headers(folder, only)
    where = only or folder
    if not headers:
        why = "" if skipped is None else f" ({skipped})"
        raise VolumeError(f"{where}: no DICOM image in {folder}{why}")
    if only is not None:
        series = next((k for k, v in headers.items() if any(f == only for f, _ in v)), None)
        if series is None:
            raise VolumeError(f"{only}: a DICOM file without an image")
    elif len(headers) == 1:
        series = next(iter(headers))
    else:
        listed = "; ".join(
            f"{v[0][1].get('Modality', '?')} {len(v)} slice(s) ({v[0][0].name})"
            for v in headers.values()
        )
        raise VolumeError(
            f"{folder}: {len(headers)} series ({listed}): give one file of the series wanted"
        )
    images: list[_Image] = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for f, _ in headers[series]:
            ds = pydicom.dcmread(f)
            if int(ds.get("NumberOfFrames", 1) or 1) > 1:
                images += _frames(f, ds)
            else:
                images.append(_image(f, ds))
        modality = str(getattr(headers[series][0][1], "Modality", "")) or None
    volume = _stack(where, images, modality, voxel_mm, max_gap_mm)
    return volume if skipped is None else replace(volume, skipped=skipped)


def _series_headers(
    folder: Path, only: Path | None
) -> tuple[dict[str, list[tuple[Path, Any]]], SkippedFiles | None]:
    """The headers (pydicom datasets without pixels) of the folder's image files by series,
    and the files left out, each with why: not DICOM, unreadable, or DICOM without an image.
    The file `only`, if it cannot be read, is refused."""
    import warnings

    import pydicom
    from pydicom.errors import InvalidDicomError

    headers: dict[str, list[tuple[Path, Any]]] = {}
    skipped: list[tuple[str, str]] = []
    files = sorted(p for p in folder.iterdir() if p.is_file())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # pydicom warns on the VR quirks it reads through
        for f in files:
            try:
                ds = pydicom.dcmread(f, stop_before_pixels=True)
            except Exception as exc:  # pydicom raises many kinds for a file it cannot read
                if only is not None and f == only:
                    raise VolumeError(f"{only}: not a volume (NIfTI, NRRD or DICOM)") from None
                why = "not DICOM" if isinstance(exc, InvalidDicomError) else _first_line(exc)
                skipped.append((f.name, why))
                continue
            if "Rows" in ds and "Columns" in ds:
                headers.setdefault(str(ds.get("SeriesInstanceUID", "?")), []).append((f, ds))
            else:
                skipped.append((f.name, "DICOM without an image"))
    if not skipped:
        return headers, None
    return headers, SkippedFiles(str(folder), len(files), tuple(skipped))


def _first_line(exc: BaseException) -> str:
    """The kind of an exception and the first line of its message."""
    text = str(exc).strip()
    return f"{type(exc).__name__}: {text.splitlines()[0]}" if text else type(exc).__name__


@dataclass(frozen=True, eq=False)
class _Image:
    """One slice: where it came from, its orientation (6,), position (3,) [mm], pixel
    spacing (between rows, between columns) [mm] and values (rows, columns)."""

    name: str
    orientation: np.ndarray
    position: np.ndarray
    pixel: np.ndarray
    values: np.ndarray


def _floats(value: Any) -> np.ndarray:
    """A DICOM multi-valued number (pydicom's MultiValue of DSfloat) as floats."""
    return np.array([float(v) for v in value], dtype=float)


def _pixels(f: Path, ds: Any) -> np.ndarray:
    """The decoded pixel data (compressed ones through pydicom's plugins); one line if not."""
    try:
        return np.asarray(ds.pixel_array)
    except Exception as exc:  # a codec missing or the data broken: pydicom raises many kinds
        syntax = getattr(getattr(ds, "file_meta", None), "TransferSyntaxUID", None)
        name = getattr(syntax, "name", syntax)
        raise VolumeError(f"{f}: its pixel data ({name}) cannot be decoded: {exc}") from None


def _image(f: Path, ds: Any) -> _Image:
    """A classic single-frame slice."""
    for tag in ("ImagePositionPatient", "ImageOrientationPatient", "PixelSpacing"):
        if tag not in ds:
            raise VolumeError(f"{f}: DICOM slice without {tag}: no patient frame")
    values = _pixels(f, ds).astype(np.float32) * float(ds.get("RescaleSlope", 1.0)) + float(
        ds.get("RescaleIntercept", 0.0)
    )
    return _Image(
        f.name,
        _floats(ds.ImageOrientationPatient),
        _floats(ds.ImagePositionPatient),
        _floats(ds.PixelSpacing),
        values,
    )


def _frames(f: Path, ds: Any) -> list[_Image]:
    """The frames of an enhanced (multi-frame) image: each frame's functional groups, else
    the shared ones."""
    shared = (
        ds.SharedFunctionalGroupsSequence[0] if "SharedFunctionalGroupsSequence" in ds else None
    )
    if "PerFrameFunctionalGroupsSequence" not in ds:
        raise VolumeError(f"{f}: a multi-frame image without per-frame positions")

    def find(group: Any, sequence: str, tag: str) -> Any:
        for g in (group, shared):
            if g is not None and sequence in g and tag in g[sequence][0]:
                return g[sequence][0][tag].value
        return None

    pixels = _pixels(f, ds)
    out = []
    for k, group in enumerate(ds.PerFrameFunctionalGroupsSequence):
        position = find(group, "PlanePositionSequence", "ImagePositionPatient")
        orientation = find(group, "PlaneOrientationSequence", "ImageOrientationPatient")
        pixel = find(group, "PixelMeasuresSequence", "PixelSpacing")
        if position is None or orientation is None or pixel is None:
            raise VolumeError(f"{f}: frame {k} without its position, orientation or spacing")
        slope = find(group, "PixelValueTransformationSequence", "RescaleSlope")
        intercept = find(group, "PixelValueTransformationSequence", "RescaleIntercept")
        slope = float(ds.get("RescaleSlope", 1.0) if slope is None else slope)
        intercept = float(ds.get("RescaleIntercept", 0.0) if intercept is None else intercept)
        values = pixels[k].astype(np.float32) * slope + intercept
        out.append(_Image(f"{f.name}[{k}]", _floats(orientation), _floats(position),
                          _floats(pixel), values))  # fmt: skip
    return out


def _stack(
    where: Path,
    images: list[_Image],
    modality: str | None,
    voxel_mm: tuple[float, float, float] | None,
    max_gap_mm: float,
) -> Volume:
    """Slices sorted along their normal into a volume: one orientation, one size, no gap; on
    their own grid if it is regular, else resampled (models.ct.regular)."""
    orientation = images[0].orientation
    for image in images[1:]:
        if np.abs(image.orientation - orientation).max() > 1e-4:
            raise VolumeError(f"{where}: mixed slice orientations ({images[0].name}, {image.name})")
    if len(images) < 2:
        raise VolumeError(f"{where}: one slice is no volume")
    row, col = orientation[:3], orientation[3:]
    normal = np.cross(row, col)
    positions = np.array([image.position for image in images])
    order = np.argsort(positions @ normal, kind="stable")
    images = [images[k] for k in order]
    positions = positions[order]
    shapes = {image.values.shape for image in images}
    if len(shapes) != 1:
        raise VolumeError(f"{where}: slices of different sizes {sorted(shapes)}")
    pixels = {tuple(np.round(image.pixel, 6)) for image in images}
    if len(pixels) != 1:
        raise VolumeError(f"{where}: slices of different pixel spacings {sorted(pixels)} mm")
    pixel = images[0].pixel  # between rows, between columns
    data = np.stack([image.values for image in images], axis=-1)  # (rows j, columns i, k)
    data = np.transpose(data, (1, 0, 2))  # (i, j, k)
    stack = SliceStack(
        data,
        positions,
        row / np.linalg.norm(row),
        col / np.linalg.norm(col),
        np.array([pixel[1], pixel[0]]),
        tuple(image.name for image in images),
    )
    steps = check_steps(stack, str(where), max_gap_mm)
    if voxel_mm is not None or not is_regular(stack, steps):
        return resample(stack, steps, voxel_mm, modality, str(where))
    affine = np.eye(4)
    affine[:3, 0] = row * pixel[1]
    affine[:3, 1] = col * pixel[0]
    affine[:3, 2] = (positions[-1] - positions[0]) / (len(images) - 1)
    affine[:3, 3] = positions[0]
    return Volume(data, affine, modality, "LPS", str(where))
