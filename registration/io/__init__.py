"""Reading scans and models from the files that scanners and CAD tools write.

Points: .xyz / .txt / .pts (x y z per line; an optional first line holding the count, which
must then match the rows; extra columns ignored), .csv (comma separated, an optional header
line), .npy ((N, 3) array), .ply (a point cloud, or a range-scan mesh whose vertices are the
points), .pcd (PCL: ascii, binary or binary_compressed), .e57 (every scan in the file, in
the file's common frame), .las / .laz. Models: a triangle mesh (.stl, .obj, .ply with faces,
.off), or any point file (a point model).

Every reader raises FormatError naming the file and what is wrong: a missing or empty file,
a folder, a truncated binary, a wrong header, NaN or inf (counted), a count line that
disagrees with the rows, points all on one line, a size that looks like the wrong units.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from registration.io.mesh_files import MESH_FORMATS, read_mesh
from registration.io.scanner_files import read_e57, read_las, read_pcd
from registration.io.text import read_csv, read_npy, read_xyz
from registration.registration_errors import FormatError, InputError
from registration.rigid import Array
from registration.shapes.base import Shape, check_points
from registration.shapes.mesh_shape import MeshModel
from registration.shapes.points import PointModel

UNITS: dict[str, float] = {"m": 1.0, "mm": 1e-3}
POINT_FORMATS: tuple[str, ...] = (
    ".xyz", ".txt", ".pts", ".csv", ".npy", ".ply", ".pcd", ".e57", ".las", ".laz",
)  # fmt: skip
#: Plausible sizes of a scanned object or cell [m]; outside, the units are wrong.
SIZE_RANGE_M: tuple[float, float] = (2e-4, 100.0)
#: The points' second spread (singular value) over their first under which they lie on one
#: line within what a file holds (float32 coordinates in PLY, PCD and LAS files).
COLLINEAR_RATIO: float = 1e-6


def _existing(path: str | Path, valid: tuple[str, ...], what: str) -> Path:
    p = Path(path)
    if p.is_dir():
        raise FormatError(f"{p} is a folder, not a {what} file; valid: {', '.join(valid)}")
    if not p.is_file():
        raise FormatError(f"{what} file not found: {p}")
    if p.suffix.lower() not in valid:
        raise FormatError(
            f"{what} file {p} has unknown format {p.suffix or '(none)'!r}; valid: "
            f"{', '.join(valid)}"
        )
    if p.stat().st_size == 0:
        raise FormatError(f"{p}: the file is empty")
    return p


def unit_scale(units: str) -> float:
    """Metres per file unit for "m" or "mm"."""
    if units not in UNITS:
        raise InputError(f"unknown units {units!r}; valid: {', '.join(UNITS)}")
    return UNITS[units]


def check_finite(path: Path, points: Array, what: str = "points") -> None:
    """Refuse coordinates (N, 3) that are NaN or inf, counted: how many, in how many of the
    `what` (points or vertices), the first one's row."""
    bad = ~np.isfinite(points)
    if not bad.any():
        return
    rows = bad.any(axis=1)
    raise FormatError(
        f"{path}: {int(bad.sum())} non-finite coordinate(s) (NaN or inf) in {int(rows.sum())} "
        f"of its {len(points)} {what} (the first in row {int(np.flatnonzero(rows)[0])}, "
        f"counting from 0); every coordinate must be a finite number"
    )


def check_spread(path: Path, points: Array, what: str = "points") -> None:
    """Refuse points (N, 3) that cannot locate a rigid pose: fewer than 3, or all on one line
    (or one point) within COLLINEAR_RATIO. Points on one plane are a surface and pass."""
    need = "a rigid match needs at least 3 points spanning a surface"
    if len(points) < 3:
        raise FormatError(f"{path}: it holds {len(points)} {what}; {need}")
    s = np.linalg.svd(points - points.mean(axis=0), compute_uv=False)
    if s[0] == 0:
        raise FormatError(f"{path}: its {len(points)} {what} are all one point; {need}")
    if s[1] <= COLLINEAR_RATIO * s[0]:
        raise FormatError(
            f"{path}: its {len(points)} {what} are collinear (all on one line); {need}"
        )


def check_size(path: Path, points_m: Array, units: str) -> None:
    """Refuse coordinates whose size [m] only the wrong units explain, with the fix."""
    extent = float(np.linalg.norm(np.ptp(points_m, axis=0)))
    lo, hi = SIZE_RANGE_M
    if lo <= extent <= hi:
        return
    hint = ""
    for name, scale in UNITS.items():
        size = extent / UNITS[units] * scale
        if name != units and 1e-3 <= size <= 10.0:
            hint = f"; with --units {name} it would be {size:.4g} m"
    raise FormatError(
        f"{path}: the points span {extent:.4g} m in {units}, which looks like the wrong units{hint}"
    )


def _read_points(p: Path) -> Array:
    suffix = p.suffix.lower()
    if suffix == ".npy":
        return read_npy(p)
    if suffix == ".csv":
        return read_csv(p)
    if suffix in (".xyz", ".txt", ".pts"):
        return read_xyz(p)
    if suffix == ".ply":
        return read_mesh(p, points_only=True)[0]
    if suffix == ".pcd":
        return read_pcd(p)
    if suffix == ".e57":
        return read_e57(p)
    return read_las(p)


def load_points(path: str | Path, units: str = "m") -> Array:
    """Points (N, 3) [m] from a point file in `units` ("m" or "mm")."""
    scale = unit_scale(units)
    p = _existing(path, POINT_FORMATS, "points")
    points = _read_points(p)
    if points.ndim == 2 and points.shape[1:] == (3,):
        check_finite(p, points)
    try:
        points = check_points(points, f"points in {p}", minimum=1)
    except InputError as exc:
        raise FormatError(str(exc)) from None
    check_spread(p, points)
    points = points * scale
    check_size(p, points, units)
    return points


def load_model(path: str | Path, units: str = "m") -> Shape:
    """A model Shape [m] from a mesh file or a point file in `units` ("m" or "mm")."""
    scale = unit_scale(units)
    p = _existing(path, tuple(dict.fromkeys(MESH_FORMATS + POINT_FORMATS)), "model")
    if p.suffix.lower() not in MESH_FORMATS:
        return PointModel(load_points(p, units))
    vertices, faces = read_mesh(p, points_only=False)
    check_finite(p, vertices, "vertices")
    check_spread(p, vertices, "vertices")
    vertices = vertices * scale
    check_size(p, vertices, units)
    if faces is None:
        return PointModel(vertices)  # a PLY point cloud
    try:
        return MeshModel(vertices, faces)
    except InputError as exc:
        raise FormatError(f"{p}: {exc}") from None


TARGET_FORMATS: tuple[str, ...] = (".json", ".xyz", ".txt", ".csv", ".npy")


def load_targets(path: str | Path, units: str = "m") -> tuple[tuple[str, ...], Array]:
    """Named targets (K, 3) [m] in the model frame, from a JSON file ({"name": [x, y, z]}
    or [[x, y, z], ...]) or a point file, in `units`."""
    scale = unit_scale(units)
    p = _existing(path, TARGET_FORMATS, "targets")
    if p.suffix.lower() == ".json":
        try:
            raw = json.loads(p.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise FormatError(f"{p}: not valid JSON ({exc})") from None
        items = list(raw.items()) if isinstance(raw, dict) else list(enumerate(raw or []))
        try:
            points = np.array([[float(v) for v in xyz] for _, xyz in items], dtype=float)
        except (TypeError, ValueError):
            raise FormatError(
                f'{p}: targets must be {{"name": [x, y, z], ...}} or [[x, y, z], ...]'
            ) from None
        names = tuple(str(k) if isinstance(raw, dict) else f"t{k}" for k, _ in items)
    else:
        points = _read_points(p)
        names = tuple(f"t{k}" for k in range(len(points)))
    if points.ndim != 2 or points.shape[1:] != (3,) or len(points) == 0:
        raise FormatError(f"{p}: expected at least one target x, y, z; got shape {points.shape}")
    if not np.isfinite(points).all():
        raise FormatError(f"{p}: a target holds NaN or inf")
    return names, points * scale


POSE_FORMATS: tuple[str, ...] = (".json", ".txt", ".csv", ".npy")


def load_pose(path: str | Path, units: str = "m") -> Array:
    """A rigid transform (4, 4), its translation in `units`, returned in metres: a JSON file
    holding a 4 x 4 list or an object with "T_model_data" (the result file of `twincell
    register --json`), a text or CSV file of four rows of four numbers, or a .npy array."""
    scale = unit_scale(units)
    p = _existing(path, POSE_FORMATS, "pose")
    suffix = p.suffix.lower()
    try:
        if suffix == ".json":
            raw = json.loads(p.read_text())
            T = np.asarray(raw["T_model_data"] if isinstance(raw, dict) else raw, dtype=float)
        elif suffix == ".npy":
            T = np.asarray(np.load(p, allow_pickle=False), dtype=float)
        else:
            T = np.loadtxt(p, delimiter="," if suffix == ".csv" else None, ndmin=2)
    except (ValueError, TypeError, KeyError, json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise FormatError(f"{p}: not a 4 x 4 transform ({type(exc).__name__}: {exc})") from None
    if T.shape != (4, 4) or not np.isfinite(T).all():
        raise FormatError(f"{p}: expected a finite 4 x 4 transform; got shape {T.shape}")
    R = T[:3, :3]
    if (
        not np.allclose(R.T @ R, np.eye(3), atol=1e-5)
        or np.linalg.det(R) < 0
        or not np.allclose(T[3], [0.0, 0.0, 0.0, 1.0])
    ):
        raise FormatError(f"{p}: not a rigid transform (its 3 x 3 block is no rotation)")
    T = T.copy()
    T[:3, 3] *= scale
    return T


__all__ = [
    "MESH_FORMATS",
    "POINT_FORMATS",
    "POSE_FORMATS",
    "TARGET_FORMATS",
    "UNITS",
    "load_model",
    "load_points",
    "load_pose",
    "load_targets",
]
