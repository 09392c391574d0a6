"""Implicit solids: signed-distance-like functions on point arrays, and their meshing.

Every function takes points `p` (N, 3) and returns (N,) values, negative inside, positive
outside, close to the Euclidean distance near the surface. Units are whatever the caller
uses (the skull is designed in millimetres and scaled to metres after meshing).
"""

from __future__ import annotations

from collections.abc import Callable

import igl
import numpy as np
import trimesh

from models.model_errors import ModelParameterError

_COARSE = 4
_BAND = 2.0
ImplicitFn = Callable[[np.ndarray], np.ndarray]


def ellipsoid(p: np.ndarray, centre: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """Approximate signed distance to an ellipsoid (exact on the surface, first order near it)."""
    q = (p - centre) / radii
    k0 = np.sqrt(np.einsum("ij,ij->i", q, q))
    q /= radii
    k1 = np.sqrt(np.einsum("ij,ij->i", q, q))
    return k0 * (k0 - 1.0) / np.maximum(k1, 1e-12)


def capsule(
    p: np.ndarray, a: np.ndarray, b: np.ndarray, radius: float, cap: float = np.inf
) -> np.ndarray:
    """Signed distance to the capsule of `radius` around the segment a-b, min(distance, cap)."""
    path = np.array([a, b], dtype=float)
    return tube(p, path, np.array([radius, radius], dtype=float), cap)


def tube(p: np.ndarray, path: np.ndarray, radii: np.ndarray, cap: float = np.inf) -> np.ndarray:
    """Distance to a tube around the polyline `path` (K, 3) with radius `radii` (K,) at its nodes.

    The radius is interpolated linearly along each segment; the result is the minimum over the
    segments (a union of tapered capsules), clipped from above at `cap`: min(distance, cap).
    Points farther than `cap` from the tube's bounding box are not evaluated (they give `cap`).
    """
    out = np.full(len(p), float(cap))
    lo = path.min(axis=0) - radii.max() - cap
    hi = path.max(axis=0) + radii.max() + cap
    inside = np.flatnonzero(np.all((p >= lo) & (p <= hi), axis=1))
    if len(inside) == 0:
        return out
    p = p[inside]
    constant = bool(np.all(radii == radii[0]))
    best = np.full(len(p), np.inf)
    for a, b, ra, rb in zip(path[:-1], path[1:], radii[:-1], radii[1:], strict=True):
        ab = b - a
        pa = p - a
        t = np.clip((pa @ ab) / float(ab @ ab), 0.0, 1.0)
        pa -= t[:, None] * ab
        d2 = np.einsum("ij,ij->i", pa, pa)
        if constant:  # minimum of squared distances, one square root at the end
            np.minimum(best, d2, out=best)
        else:
            np.minimum(best, np.sqrt(d2) - (ra + t * (rb - ra)), out=best)
    out[inside] = np.minimum(np.sqrt(best) - radii[0] if constant else best, cap)
    return out


def smooth_union(a: np.ndarray, b: np.ndarray, k: float) -> np.ndarray:
    """Polynomial smooth minimum of two distance fields with blend width `k`."""
    h = np.clip(0.5 + 0.5 * (b - a) / k, 0.0, 1.0)
    return b * (1.0 - h) + a * h - k * h * (1.0 - h)


def smooth_subtract(a: np.ndarray, b: np.ndarray, k: float) -> np.ndarray:
    """Solid `a` minus solid `b`, with a fillet of width `k` along the cut."""
    return -smooth_union(-a, b, k)


def smooth_intersect(a: np.ndarray, b: np.ndarray, k: float) -> np.ndarray:
    """Intersection of solids `a` and `b`, with a fillet of width `k`."""
    return -smooth_union(-a, -b, k)


def _narrow_band_values(
    fn: ImplicitFn, axes: list[np.ndarray], grid: np.ndarray, spacing: float
) -> np.ndarray:
    """`fn` on the grid points (x fastest), evaluated exactly only near the surface.

    The grid `_COARSE` times coarser is evaluated first; each fine point takes the value of its
    nearest coarse point (at most `_COARSE` * spacing * sqrt(3) / 2 away), and the fine points
    whose coarse value lies within `_BAND` coarse steps of zero are evaluated exactly. Farther
    points keep the coarse value, whose sign is right there; marching cubes uses only the
    signs and the exact values next to the surface.
    """
    index = [np.arange(len(a)) for a in axes]
    nearest = [np.rint(i / _COARSE).astype(int) for i in index]
    coarse_axes = [
        a[np.minimum(np.arange(n[-1] + 1) * _COARSE, len(a) - 1)]
        for a, n in zip(axes, nearest, strict=True)
    ]
    cz, cy, cx = np.meshgrid(coarse_axes[2], coarse_axes[1], coarse_axes[0], indexing="ij")
    coarse = fn(np.column_stack([cx.ravel(), cy.ravel(), cz.ravel()])).reshape(cz.shape)
    values = coarse[np.ix_(nearest[2], nearest[1], nearest[0])].ravel()
    near = np.abs(values) < _BAND * _COARSE * spacing
    values[near] = fn(grid[near])
    return values


def mesh_implicit(
    fn: ImplicitFn, lower: np.ndarray, upper: np.ndarray, spacing: float
) -> trimesh.Trimesh:
    """Marching cubes of the zero level set of `fn` on a regular grid over the box lower-upper.

    The box must enclose the solid with a margin (the function must be positive on its
    boundary), so that the surface comes out closed. Returns the outward-oriented mesh.
    """
    if not spacing > 0:
        raise ModelParameterError(f"grid spacing must be positive, got {spacing}")
    axes = [np.arange(lo, hi + spacing, spacing) for lo, hi in zip(lower, upper, strict=True)]
    nx, ny, nz = (len(a) for a in axes)
    zz, yy, xx = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")  # x varies fastest
    grid = np.column_stack([xx.ravel(), yy.ravel(), zz.ravel()])
    values = _narrow_band_values(fn, axes, grid, spacing)
    boundary = np.zeros((nz, ny, nx), dtype=bool)
    boundary[[0, -1], :, :] = boundary[:, [0, -1], :] = boundary[:, :, [0, -1]] = True
    if (values.reshape(nz, ny, nx)[boundary] <= 0).any():
        raise ModelParameterError("the solid reaches the boundary of its meshing box")
    # A grid value on (or within rounding of) the level set puts several surface vertices
    # on one grid corner: zero-area triangles that a later vertex merge turns non-manifold.
    # Values within 1e-3 spacings of zero are pushed to that distance (a shift of at most
    # 1e-3 spacings of the surface); libigl shares the vertices of a cube edge already, so
    # the mesh is taken as it is, without merging by distance.
    eps = 1e-3 * spacing
    small = np.abs(values) < eps
    values[small] = np.where(values[small] < 0, -eps, eps)
    vertices, faces, _ = igl.marching_cubes(values, grid, nx, ny, nz, 0.0)
    mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
    if mesh.volume < 0:
        mesh.invert()
    return mesh
