"""What a match is asked: its modes, its inputs checked, and the request they make.

`match` (matcher.py) checks its data, model and options here (InputError names the first
that is wrong and why) and hands the steps one `MatchRequest`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal, TypeGuard

import numpy as np

from registration.icp import Variant
from registration.kernels import Kernel
from registration.quality import ScanPasses
from registration.registration_errors import InputError
from registration.rigid import Array
from registration.search import SearchSettings
from registration.shapes.base import Shape, check_points
from registration.shapes.mesh_shape import MeshModel
from registration.shapes.points import PointModel
from registration.verdict import Acceptance

Mode = Literal["auto", "global", "local", "refine"]
MODES: tuple[str, ...] = ("auto", "global", "local", "refine")


def is_mode(name: str) -> TypeGuard[Mode]:
    """Whether `name` is one of the `MODES`."""
    return name in MODES


Progress = Callable[[str], None]

#: A scan more than this many times larger or smaller than the model is in other units.
_UNITS_RATIO = 30.0


def as_shape(model: Shape | Array | object) -> Shape:
    """A Shape from a Shape, an (N, 3) point array, or an object with vertices and faces."""
    if isinstance(model, Shape):
        return model
    if hasattr(model, "vertices") and hasattr(model, "faces"):
        return MeshModel(model.vertices, model.faces)
    if isinstance(model, np.ndarray | list | tuple):
        return PointModel(np.asarray(model, dtype=float))
    raise InputError(
        f"model must be a Shape (PointModel, SegmentModel, MeshModel, ParametricModel), an "
        f"(N, 3) array or a mesh with vertices and faces; got {type(model).__name__}"
    )


def check_data(data: Array) -> Array:
    """Validate data points: (N, 3), finite, N >= 3, not all on one line."""
    data = check_points(data, "data points", minimum=3)
    s = np.linalg.svd(data - data.mean(axis=0), compute_uv=False)
    if s[0] == 0 or s[1] <= 1e-9 * s[0]:
        raise InputError(
            f"the {len(data)} data points are all on one line (or one point): a rigid pose "
            f"needs points spanning at least a plane"
        )
    return data


def data_extent(data: Array) -> float:
    """Diagonal of the box holding the middle 96 % of the data along each axis."""
    lo, hi = np.percentile(data[:: max(1, len(data) // 5000)], [2, 98], axis=0)
    return float(np.linalg.norm(hi - lo))


def check_units(data: Array, shape: Shape) -> None:
    """Refuse data and a model whose sizes differ by a factor that only units explain."""
    size = data_extent(data)
    ratio = size / shape.extent
    if not 1.0 / _UNITS_RATIO < ratio < _UNITS_RATIO:
        guess = "mm data against a model in m" if ratio > 1 else "data in m against a model in mm"
        raise InputError(
            f"the data span {size:.4g} and the model {shape.extent:.4g} (same units): a "
            f"factor of {ratio:.3g}, which looks like {guess}; give both in the same units"
        )


def resolution_floor(data: Array, extent: float) -> float:
    """What the data can resolve without a stated noise [length units]: one part in 10,000
    of the model's size, or a hundredth of the data's point spacing if that is larger."""
    pool = data[:: max(1, len(data) // 2000)]
    if len(pool) >= 2:
        from scipy.spatial import cKDTree

        d, _ = cKDTree(pool).query(pool, k=2)
        spacing = float(np.median(d[:, 1])) * np.sqrt(len(pool) / len(data))
    else:
        spacing = 0.0
    return max(1e-4 * extent, 0.01 * spacing)


def _check_pose(T: Array, what: str) -> Array:
    T = np.asarray(T, dtype=float)
    if T.shape != (4, 4) or not np.isfinite(T).all():
        raise InputError(f"{what} must be a finite (4, 4) matrix; got shape {T.shape}")
    R = T[:3, :3]
    if not np.allclose(R.T @ R, np.eye(3), atol=1e-6) or np.linalg.det(R) < 0:
        raise InputError(f"{what} must be a rigid transform: its 3 x 3 block is no rotation")
    return T


def check_options(
    data: Array,
    mode: str,
    T_init: Array | None,
    targets: Array | None,
    noise: float | None,
    seed: int,
    passes: ScanPasses | None,
) -> tuple[Array, Array | None, Array | None]:
    """The data (N, 3), T_init (4, 4) and the targets (K, 3) of `match` checked, as float
    arrays; InputError names the first input (or option) that is wrong and why."""
    if mode not in MODES:
        raise InputError(f"unknown matching mode {mode!r}; valid: {', '.join(MODES)}")
    data = check_data(data)
    if passes is not None and np.shape(passes.labels) != (len(data),):
        raise InputError(
            f"passes.labels must give one pass per data point ({len(data)}); got shape "
            f"{np.shape(passes.labels)}"
        )
    if mode == "refine" and T_init is None:
        raise InputError("mode 'refine' needs T_init, the (4, 4) initial pose")
    if T_init is not None:
        T_init = _check_pose(T_init, "T_init")
    if targets is not None:
        targets = check_points(np.atleast_2d(targets), "targets", minimum=1)
    if noise is not None and not (np.isfinite(noise) and noise > 0):
        raise InputError(f"noise must be a finite number > 0 (the sensor's sigma); got {noise}")
    if not isinstance(seed, int | np.integer) or seed < 0:
        raise InputError(f"seed must be an integer >= 0; got {seed!r}")
    return data, T_init, targets


@dataclass(frozen=True, eq=False)
class MatchRequest:
    """A match's inputs, checked (see `match`): the data (N, 3) and the model, the options
    (defaults filled in, but the kernel, which depends on the floor), the progress callable
    and the wall time the match started at [s]."""

    data: Array
    shape: Shape
    mode: str
    T_init: Array | None
    targets: Array | None
    noise: float | None
    seed: int
    variant: Variant
    kernel: Kernel | None
    acceptance: Acceptance
    settings: SearchSettings
    max_iterations: int
    say: Progress
    passes: ScanPasses | None
    t_start: float
