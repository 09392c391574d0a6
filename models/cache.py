"""A disk cache of the built-in models that take seconds to build (the skull phantom and its
convex contact pieces), in the user's cache folder.

A model is stored by its inputs: the builder's name, its seed, and a hash of the `models`
package's own code, so that a changed generator never reads a file an older one wrote. The
file is a numpy .npz (no pickle) written atomically, so parallel runs may share the folder.
Other caches of the project (the scan plans') keep their files in subfolders here.
`TWINCELL_NO_CACHE=1` turns them all off; a caller turns them off for its own use with
`use_cache=False` (`twincell run --no-cache` does for its run). `TWINCELL_CACHE_DIR` moves
it (default: platformdirs' user cache folder, `twincell/models`).
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import os
from collections.abc import Callable
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
import platformdirs

from models.atomic import write_atomic
from models.mesh import TriangleMesh
from models.model import ObjectModel
from models.targets import BurrHole

#: The layout of the cache's files; a file of another layout is built anew.
FORMAT = 1


def enabled(use_cache: bool = True) -> bool:
    """Whether the cache is used: the caller's `use_cache`, unless TWINCELL_NO_CACHE turns it
    off."""
    return use_cache and os.environ.get("TWINCELL_NO_CACHE", "") in ("", "0")


def folder() -> Path:
    """Where the cache's files are."""
    root = os.environ.get("TWINCELL_CACHE_DIR")
    return Path(root) if root else Path(platformdirs.user_cache_dir("twincell")) / "models"


@lru_cache(maxsize=1)
def code_hash() -> str:
    """A hash of the `models` package's source: a change of any generator changes it."""
    digest = hashlib.sha256()
    for path in sorted(Path(__file__).parent.rglob("*.py")):
        digest.update(path.relative_to(Path(__file__).parent).as_posix().encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def key(name: str, seed: int) -> str:
    """The cache key of the built-in model `name` with `seed`."""
    return f"{name}-seed{seed}-f{FORMAT}-{code_hash()}"


#: The built-in models the cache holds (the others build in a fraction of a second).
CACHED = ("skull",)


def used_key(name: str, seed: int, use_cache: bool = True) -> str | None:
    """The key a run of the built-in model `name` with `seed` reads or writes, or None
    (the cache is off, see `enabled`, or does not hold that model)."""
    return key(name, seed) if enabled(use_cache) and name in CACHED else None


def cached(
    name: str, seed: int, build: Callable[[int], ObjectModel], use_cache: bool = True
) -> ObjectModel:
    """The built-in model `name` (seed `seed`) from the cache, or built by `build(seed)` and
    stored; the same model either way, to the bit. With the cache off (see `enabled`),
    built and not stored."""
    if not enabled(use_cache):
        return build(seed)
    path = folder() / f"{key(name, seed)}.npz"
    if path.is_file():
        try:
            return _read(path)
        except (OSError, ValueError, KeyError):
            pass  # a damaged file: build anew and replace it
    model = build(seed)
    with contextlib.suppress(OSError):  # a read-only cache folder costs time, not results
        write_atomic(path, lambda tmp: tmp.write_bytes(_encode(model)))
    return model


def _encode(model: ObjectModel) -> bytes:
    """The .npz bytes of a model with a mesh, convex pieces and burr holes (no frames, probe
    lines, points or analytic surface: the cached builders make none)."""
    if model.frames or model.probe_lines or model.points is not None or model.surface:
        raise ValueError(f"the cache stores meshes, pieces and burr holes; {model.name} has more")
    arrays: dict[str, Any] = {
        "format": np.array(FORMAT),
        "name": np.array(model.name),
        "source": np.array(model.source),
        "vertices": model.mesh.vertices,
        "faces": model.mesh.faces,
        "pieces": np.array(len(model.convex_pieces)),
        "hole_names": np.array([h.name for h in model.burr_holes]),
        "hole_entries": np.array([h.p_entry for h in model.burr_holes]).reshape(-1, 3),
        "hole_directions": np.array([h.direction for h in model.burr_holes]).reshape(-1, 3),
        "hole_depths": np.array([h.depth for h in model.burr_holes]),
    }
    for k, piece in enumerate(model.convex_pieces):
        arrays[f"piece{k}_vertices"] = piece.vertices
        arrays[f"piece{k}_faces"] = piece.faces
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    return buffer.getvalue()


def _read(path: Path) -> ObjectModel:
    with np.load(path, allow_pickle=False) as data:
        if int(data["format"]) != FORMAT:
            raise ValueError(f"{path}: cache format {int(data['format'])}, expected {FORMAT}")
        pieces = tuple(
            TriangleMesh(data[f"piece{k}_vertices"], data[f"piece{k}_faces"])
            for k in range(int(data["pieces"]))
        )
        holes = []
        for name, p, d, depth in zip(
            data["hole_names"], data["hole_entries"], data["hole_directions"],
            data["hole_depths"], strict=True,
        ):  # fmt: skip
            hole = BurrHole(str(name), p, d, float(depth))
            # The stored direction is the built one to the bit; BurrHole's normalization
            # of an already unit vector may move its last digit.
            direction = np.array(d, dtype=float)
            direction.setflags(write=False)
            object.__setattr__(hole, "direction", direction)
            holes.append(hole)
        return ObjectModel(
            name=str(data["name"]),
            mesh=TriangleMesh(data["vertices"], data["faces"]),
            convex_pieces=pieces,
            burr_holes=tuple(holes),
            source=str(data["source"]),
        )
