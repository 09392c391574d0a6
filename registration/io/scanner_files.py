"""Scanner files, read by the libraries their formats are maintained in: PCD (pypcd4),
E57 (pye57, libE57Format) and LAS/LAZ (laspy, lazrs for LAZ)."""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from registration.registration_errors import FormatError, first_line
from registration.rigid import Array


def read_pcd(p: Path) -> Array:
    """x, y, z of a PCL point cloud (DATA ascii, binary or binary_compressed)."""
    from pypcd4 import PointCloud

    with p.open("rb") as f:
        if not f.read(256).lstrip().startswith((b"#", b"VERSION", b"FIELDS")):
            raise FormatError(f"{p}: not a PCD file (no PCD header)")
    try:
        cloud = PointCloud.from_path(p)
    except Exception as exc:  # pypcd4 raises ValueError, KeyError, struct errors...
        raise FormatError(f"{p}: cannot be read as PCD: {first_line(exc)}") from None
    fields = list(cloud.fields)
    missing = [f for f in ("x", "y", "z") if f not in fields]
    if missing:
        raise FormatError(f"{p}: the PCD has no field {', '.join(missing)} (fields: {fields})")
    declared = int(cloud.metadata.points)
    data = cloud.numpy(("x", "y", "z"))
    if len(data) != declared:
        raise FormatError(
            f"{p}: its header declares {declared} points but {len(data)} were read "
            f"(a truncated file?)"
        )
    return np.asarray(data, dtype=float)


@contextlib.contextmanager
def _quiet_stderr() -> Iterator[None]:
    """Silence what C++ libraries print to file descriptor 2 (libE57Format prints a debug
    report of every error it raises; the error itself reaches the caller as an exception)."""
    sys.stderr.flush()
    saved = os.dup(2)
    with open(os.devnull, "w") as devnull:
        os.dup2(devnull.fileno(), 2)
        try:
            yield
        finally:
            os.dup2(saved, 2)
            os.close(saved)


def read_e57(p: Path) -> Array:
    """Every scan of an E57 file, in the file's common frame (each scan's pose applied)."""
    with _quiet_stderr():
        return _read_e57(p)


def _read_e57(p: Path) -> Array:
    import pye57

    try:
        e57 = pye57.E57(str(p))
    except Exception as exc:  # libE57Format raises its own errors
        raise FormatError(f"{p}: cannot be read as E57: {first_line(exc)}") from None
    try:
        if e57.scan_count == 0:
            raise FormatError(f"{p}: the E57 file holds no scan")
        parts = []
        for k in range(e57.scan_count):
            try:
                scan = e57.read_scan(k, ignore_missing_fields=True, transform=True)
            except Exception as exc:
                raise FormatError(f"{p}: scan {k} cannot be read: {first_line(exc)}") from None
            if "cartesianX" not in scan:
                raise FormatError(f"{p}: scan {k} has no cartesian coordinates")
            parts.append(np.stack([scan["cartesianX"], scan["cartesianY"], scan["cartesianZ"]], 1))
    finally:
        e57.close()
    return np.concatenate(parts).astype(float)


def read_las(p: Path) -> Array:
    """x, y, z (scaled and offset as the header says) of a LAS or LAZ file."""
    import laspy

    try:
        las = laspy.read(p)
    except Exception as exc:  # laspy raises LaspyException and others
        raise FormatError(
            f"{p}: cannot be read as {p.suffix[1:].upper()}: {first_line(exc)}"
        ) from None
    declared = int(las.header.point_count)
    points = np.stack([np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)], axis=1)
    if len(points) != declared:
        raise FormatError(
            f"{p}: its header declares {declared} points but {len(points)} were read "
            f"(a truncated file?)"
        )
    return points.astype(float)
