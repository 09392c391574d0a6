"""The prepared-model file (.twm): a model and what `prepare` built for it, stored so that
another process reads it back instead of building it again.

The file is a numpy archive (.npz, uncompressed) of plain arrays of numbers and strings,
read with `np.load(allow_pickle=False)`: reading one runs no code from it, so a .twm from
anywhere is as safe to open as a point file. It holds
- `format` ("twincell prepared model"), `version` (the layout, FORMAT_VERSION) and `code` (a
  hash of the registration package's source, see `code_hash`): a file of another layout or
  written by other registration code is refused, since what it holds (the surface sample,
  the anchors, the symmetries) would not be what this code builds from the model, and the
  matches would differ from the model file's;
- the model's source: its file's absolute path, its SHA-256 and the units it was read in
  (every array is in metres); a source file still at that path that no longer has that
  hash makes the .twm refused as out of date;
- the model: a mesh's vertices, faces, face normals, surface sample and its normals, or a
  point model's points and normals;
- what `prepare` built: the voxel lookup (its grid, its voxels' sample indices and gaps),
  the anchors with their frames, and the symmetries, each under its cache's key.

The KD-tree over the surface sample and libigl's AABB tree over the triangles have no array
form; they are built again on reading, so that the model comes back as `prepare` leaves it.
"""

from __future__ import annotations

import hashlib
import os
import zipfile
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any, cast

import numpy as np

from registration.lookup import VoxelGrid, VoxelLookup
from registration.prepare import prepare
from registration.registration_errors import FormatError, InputError, first_line
from registration.rigid import Array
from registration.shapes.base import Shape
from registration.shapes.mesh_shape import MeshModel
from registration.shapes.points import PointModel
from registration.symmetry import Symmetry, SymmetryKind, symmetry_cache

#: What the file's `format` entry says.
FORMAT = "twincell prepared model"
#: The layout of the file's entries; a file of another layout is refused.
FORMAT_VERSION = 1
#: The suffix of a prepared-model file.
SUFFIX = ".twm"
_KINDS = ("mesh", "points")
_SYMMETRY_KINDS = ("turn", "axis", "sphere")


@lru_cache(maxsize=1)
def code_hash() -> str:
    """A hash of the registration package's source: different code may build a different
    surface sample, anchors or symmetries from the same model."""
    root = Path(__file__).parent
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        digest.update(path.relative_to(root).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def file_sha256(path: str | Path) -> str:
    """The SHA-256 of a file's bytes, in hex."""
    digest = hashlib.sha256()
    with Path(path).open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


@dataclass(frozen=True)
class ModelSource:
    """Where a prepared model came from: the model file's absolute `path`, its `sha256`, and
    the `units` ("m" or "mm") it was read in."""

    path: str
    sha256: str
    units: str

    @classmethod
    def of(cls, path: str | Path, units: str) -> ModelSource:
        """The source record of the model file at `path`, read in `units`."""
        return cls(str(Path(path).resolve()), file_sha256(path), units)


@dataclass(frozen=True)
class PreparedModel:
    """A model read from a .twm file, prepared, and the record of its source."""

    shape: Shape
    source: ModelSource


def is_prepared_file(path: str | Path) -> bool:
    """True if `path` names a prepared-model file (by its suffix)."""
    return Path(path).suffix.lower() == SUFFIX


def check_target(path: str | Path) -> Path:
    """`path` if a prepared model can be written there: its name ends in .twm, its folder
    exists."""
    p = Path(path)
    if not is_prepared_file(p):
        raise InputError(f"a prepared model file must end in {SUFFIX}; got {p.name!r}")
    if not p.parent.is_dir():
        raise InputError(f"cannot write {p}: the folder {p.parent} does not exist")
    return p


def save_prepared(shape: Shape, path: str | Path, source: ModelSource) -> Path:
    """Prepare `shape` (a MeshModel or PointModel, in metres) if it is not yet, and write it
    with what `prepare` built to `path` (which must end in .twm), atomically."""
    p = check_target(path)
    if not isinstance(shape, MeshModel | PointModel):
        raise InputError(
            f"only a mesh or a point model can be stored as a prepared model; got "
            f"{type(shape).__name__}"
        )
    prepare(shape)
    entries = _header(source, "mesh" if isinstance(shape, MeshModel) else "points")
    entries |= _shape_entries(shape) | _lookup_entries(shape.sample_lookup)
    entries |= _anchor_entries(shape) | _symmetry_entries(shape)
    tmp = p.with_name(f".{p.name}.{os.getpid()}.tmp")
    try:
        with tmp.open("wb") as f:
            np.savez(f, **cast(dict[str, Any], entries))
        tmp.replace(p)
    finally:
        tmp.unlink(missing_ok=True)
    return p


def _header(source: ModelSource, kind: str) -> dict[str, Array]:
    return {
        "format": np.array(FORMAT),
        "version": np.array(FORMAT_VERSION),
        "code": np.array(code_hash()),
        "kind": np.array(kind),
        "source_path": np.array(source.path),
        "source_sha256": np.array(source.sha256),
        "units": np.array(source.units),
    }


def _shape_entries(shape: MeshModel | PointModel) -> dict[str, Array]:
    out = {"samples": shape.samples} if isinstance(shape, MeshModel) else {"points": shape.points}
    if isinstance(shape, MeshModel):
        out |= {"vertices": shape.vertices, "faces": shape.faces}
        out["face_normals"] = shape.face_normals
    if shape.sample_normals is not None:
        out["sample_normals" if isinstance(shape, MeshModel) else "normals"] = shape.sample_normals
    return out


def _lookup_entries(lookup: VoxelLookup) -> dict[str, Array]:
    grid = lookup.grid
    return {
        "lookup_origin": np.asarray(grid.origin, dtype=float),
        "lookup_h": np.array(grid.h, dtype=float),
        "lookup_shape": np.asarray(grid.shape, dtype=np.int64),
        "lookup_reach": np.array(grid.reach, dtype=float),
        "lookup_index": lookup.index,
        "lookup_gap": lookup.gap,
    }


def _anchor_entries(shape: Shape) -> dict[str, Array]:
    cache = shape.anchor_cache()
    out: dict[str, Array] = {
        "anchor_count": np.array([count for count, _ in cache], dtype=np.int64),
        "anchor_radius": np.array([radius for _, radius in cache], dtype=float),
    }
    for k, (anchors, frames) in enumerate(cache.values()):
        out[f"anchor_points_{k}"] = anchors
        out[f"anchor_frames_{k}"] = frames
    return out


def _symmetry_entries(shape: Shape) -> dict[str, Array]:
    cache = symmetry_cache(shape)
    out: dict[str, Array] = {
        "symmetry_floor": np.array([floor for floor, _ in cache], dtype=float),
        "symmetry_seed": np.array([seed for _, seed in cache], dtype=np.int64),
    }
    for k, found in enumerate(cache.values()):
        out[f"symmetry_kind_{k}"] = np.array([s.kind for s in found], dtype="<U6")
        out[f"symmetry_axis_{k}"] = np.array([s.axis for s in found], dtype=float).reshape(-1, 3)
        out[f"symmetry_point_{k}"] = np.array([s.point for s in found], dtype=float).reshape(-1, 3)
        out[f"symmetry_angle_{k}"] = np.array([s.angle for s in found], dtype=float)
        out[f"symmetry_residual_{k}"] = np.array([s.residual for s in found], dtype=float)
    return out


def load_prepared(path: str | Path) -> PreparedModel:
    """The prepared model in a .twm file written by `save_prepared`, its trees built.

    Raises FormatError naming the file and what is wrong: not a prepared model, another
    layout or other registration code than this one's, a source file changed since, or a
    damaged file.
    """
    p = _existing(path)
    entries = _entries(p)
    source = _check_header(p, entries)
    try:
        shape = _restore(entries)
    except (KeyError, ValueError, TypeError, InputError) as exc:
        raise FormatError(f"{p}: a damaged prepared model: {exc}") from None
    # The trees that have no array form, built now as prepare leaves them.
    _ = shape.sample_tree
    if isinstance(shape, MeshModel):
        _ = shape.tree
    return PreparedModel(shape, source)


def read_source(path: str | Path) -> ModelSource:
    """The source record of a .twm file (checked as `load_prepared` checks it), read without
    its arrays: where the model came from and its units."""
    p = _existing(path)
    return _check_header(p, _entries(p, _HEADER))


def _existing(path: str | Path) -> Path:
    p = Path(path)
    if p.is_dir():
        raise FormatError(f"{p} is a folder, not a prepared model file ({SUFFIX})")
    if not p.is_file():
        raise FormatError(f"prepared model file not found: {p}")
    return p


#: The entries of the header (`_header`).
_HEADER = ("format", "version", "code", "kind", "source_path", "source_sha256", "units")


def _entries(p: Path, names: tuple[str, ...] | None = None) -> dict[str, Array]:
    """The entries `names` (default: every entry) of the archive at `p` that it holds:
    numbers and strings only, no pickled object."""
    what = f"{p}: not a prepared model (a {SUFFIX} file written by `twincell prepare`)"
    try:
        loaded = np.load(p, allow_pickle=False)
    except (OSError, ValueError, EOFError) as exc:
        raise FormatError(f"{what}: not a numpy archive ({first_line(exc)})") from None
    if not isinstance(loaded, np.lib.npyio.NpzFile):
        raise FormatError(f"{what}: a single numpy array, not an archive")
    try:
        with loaded as archive:
            wanted = archive.files if names is None else [n for n in names if n in archive]
            return {name: archive[name] for name in wanted}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        raise FormatError(f"{what}: an entry cannot be read ({first_line(exc)})") from None


def _text(entries: dict[str, Array], name: str) -> str | None:
    value = entries.get(name)
    if value is None or value.shape != () or value.dtype.kind not in "UiS":
        return None
    return str(value.item())


def _check_header(p: Path, entries: dict[str, Array]) -> ModelSource:
    """The file's source record, once its format, layout, code and source are this
    code's."""
    again = f"prepare it again: twincell prepare MODEL --out {p.name}"
    fmt = _text(entries, "format")
    if fmt != FORMAT:
        raise FormatError(
            f"{p}: a numpy archive but not a prepared model (its format entry is {fmt!r}; "
            f"expected {FORMAT!r})"
        )
    version = _text(entries, "version")
    if version != str(FORMAT_VERSION):
        raise FormatError(
            f"{p}: a prepared model of format version {version}; this twincell reads version "
            f"{FORMAT_VERSION}: {again}"
        )
    code = _text(entries, "code")
    if code != code_hash():
        raise FormatError(
            f"{p}: prepared by other registration code (code {code}; this twincell's is "
            f"{code_hash()}), which may build another surface sample, anchors or symmetries: "
            f"{again}"
        )
    fields = [_text(entries, name) for name in ("source_path", "source_sha256", "units")]
    if any(field is None for field in fields):
        raise FormatError(f"{p}: a damaged prepared model: no record of its source")
    source = ModelSource(*(str(field) for field in fields))
    if Path(source.path).is_file() and file_sha256(source.path) != source.sha256:
        raise FormatError(
            f"{p}: out of date: its model {source.path} has changed since it was prepared "
            f"(SHA-256 {source.sha256[:12]}..., now {file_sha256(source.path)[:12]}...): "
            f"prepare it again: twincell prepare {source.path} --out {p.name}"
        )
    return source


def _array(
    entries: dict[str, Array],
    name: str,
    shape: tuple[int | None, ...],
    kind: str,
    finite: bool = True,
) -> Array:
    """Entry `name`, checked: its dimensions (None: any length), its dtype's kind ("f"
    floats, "i" integers) and, if `finite`, its values."""
    a = entries[name]
    if a.ndim != len(shape) or any(n not in (None, m) for n, m in zip(shape, a.shape, strict=True)):
        raise ValueError(f"{name} has shape {a.shape}; expected {shape}")
    if a.dtype.kind != kind:
        raise ValueError(f"{name} holds {a.dtype}; expected {'floats' if kind == 'f' else 'ints'}")
    if finite and kind == "f" and not np.isfinite(a).all():
        raise ValueError(f"{name} holds NaN or inf")
    return a


def _restore(entries: dict[str, Array]) -> Shape:
    kind = _text(entries, "kind")
    if kind not in _KINDS:
        raise ValueError(f"its kind is {kind!r}; expected one of {', '.join(_KINDS)}")
    shape = _restore_mesh(entries) if kind == "mesh" else _restore_points(entries)
    shape.sample_lookup = _restore_lookup(entries, shape.samples)
    _restore_anchors(entries, shape)
    _restore_symmetries(entries, shape)
    return shape


def _restore_mesh(entries: dict[str, Array]) -> MeshModel:
    vertices = _array(entries, "vertices", (None, 3), "f")
    faces = _array(entries, "faces", (None, 3), "i")
    if len(faces) == 0 or faces.min() < 0 or faces.max() >= len(vertices):
        raise ValueError(f"its faces do not index its {len(vertices)} vertices")
    face_normals = _array(entries, "face_normals", (len(faces), 3), "f")
    samples = _array(entries, "samples", (None, 3), "f")
    sample_normals = _array(entries, "sample_normals", (len(samples), 3), "f")
    return MeshModel.restore(
        vertices, faces.astype(np.int64), face_normals, samples, sample_normals
    )


def _restore_points(entries: dict[str, Array]) -> PointModel:
    points = _array(entries, "points", (None, 3), "f")
    if len(points) < 3:
        raise ValueError(f"it holds {len(points)} model points; at least 3 are needed")
    normals = None
    if "normals" in entries:
        normals = _array(entries, "normals", (len(points), 3), "f")
    return PointModel.restore(points, normals)


def _restore_lookup(entries: dict[str, Array], samples: Array) -> VoxelLookup:
    grid = VoxelGrid(
        origin=_array(entries, "lookup_origin", (3,), "f"),
        h=float(_array(entries, "lookup_h", (), "f")),
        shape=_array(entries, "lookup_shape", (3,), "i"),
        reach=float(_array(entries, "lookup_reach", (), "f")),
    )
    index = _array(entries, "lookup_index", (None,), "i")
    if index.size and (index.min() < -1 or index.max() >= len(samples)):
        raise ValueError(f"its lookup indexes samples outside its {len(samples)}")
    gap = _array(entries, "lookup_gap", (None,), "f", finite=False)
    return VoxelLookup.restore(samples, grid, index, gap)


def _restore_anchors(entries: dict[str, Array], shape: Shape) -> None:
    counts = _array(entries, "anchor_count", (None,), "i")
    radii = _array(entries, "anchor_radius", (len(counts),), "f")
    cache = shape.anchor_cache()
    for k, (count, radius) in enumerate(zip(counts, radii, strict=True)):
        anchors = _array(entries, f"anchor_points_{k}", (None, 3), "f")
        frames = _array(entries, f"anchor_frames_{k}", (len(anchors), 3, 3), "f")
        cache[(int(count), float(radius))] = (anchors, frames)


def _restore_symmetries(entries: dict[str, Array], shape: Shape) -> None:
    floors = _array(entries, "symmetry_floor", (None,), "f")
    seeds = _array(entries, "symmetry_seed", (len(floors),), "i")
    cache = symmetry_cache(shape)
    for k, (floor, seed) in enumerate(zip(floors, seeds, strict=True)):
        kinds = entries[f"symmetry_kind_{k}"]
        n = len(kinds)
        if kinds.ndim != 1 or any(str(kind) not in _SYMMETRY_KINDS for kind in kinds):
            raise ValueError(f"symmetry_kind_{k} holds {kinds!r}")
        axes = _array(entries, f"symmetry_axis_{k}", (n, 3), "f")
        points = _array(entries, f"symmetry_point_{k}", (n, 3), "f")
        angles = _array(entries, f"symmetry_angle_{k}", (n,), "f", finite=False)
        residuals = _array(entries, f"symmetry_residual_{k}", (n,), "f")
        cache[(float(floor), int(seed))] = tuple(
            Symmetry(
                cast(SymmetryKind, str(kinds[j])),  # one of _SYMMETRY_KINDS, checked above
                axes[j],
                points[j],
                float(angles[j]),
                float(residuals[j]),
            )
            for j in range(n)
        )
