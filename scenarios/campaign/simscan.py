"""A simulated laser scan of the real object, without the cell: orthographic line-scan passes.

Each pass looks along one direction at the object in the table frame. Visible points are found
with an orthographic depth buffer (`DepthBuffer`): area-uniform samples of the real surface are
binned on the plane normal to the view; in each cell only the samples within
`depth_tolerance_m` (plus the depth a surface of their slope spans across the cell) of the
nearest one are seen (self-occlusion), and samples seen at grazing incidence (the angle between
the surface normal and the view ray beyond `max_incidence_deg`) are dropped, as a laser does.
Errors: Gaussian range noise along the view ray, a small rigid offset per pass (the arm's
absolute accuracy) plus per-point jitter (repeatability, encoders), optional spurious points.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from registration.shapes.mesh_shape import sample_surface

#: Radius of a reflective patch that returns spurious ranges [m] (the cell's laser_spurious).
PATCH_RADIUS_M = 0.01


@dataclass(frozen=True)
class ScanErrors:
    """Error magnitudes of a simulated scan.

    Attributes:
        range_sigma: laser range noise, along the ray [m].
        pass_sigma: RMS length of the rigid translation offset of each pass [m].
        pass_rotation_sigma: RMS angle of the rigid rotation offset of each pass [rad].
        jitter_sigma: per-point isotropic jitter, per axis [m].
        outlier_fraction: fraction of the points replaced by spurious ones, uniform in the
            scan's bounding box padded by 20 %.
        dropout_burst: the fraction of one pass's sweep (along y) that returns nothing (a
            laser dropout burst; the pass drawn from the seed), 0: none.
        spurious_m: range error [m] of the returns from a reflective patch (20 mm across, on
            the object's upper surface, drawn from the seed), 0: none.
    """

    range_sigma: float = 1.0e-4
    pass_sigma: float = 3.0e-4
    pass_rotation_sigma: float = 2.0e-4
    jitter_sigma: float = 5.0e-5
    outlier_fraction: float = 0.0
    dropout_burst: float = 0.0
    spurious_m: float = 0.0


@dataclass(frozen=True)
class DepthBuffer:
    """How a pass sees the surface (see the module's docstring).

    Attributes:
        cell_m: the side of the depth buffer's square cells, on the plane normal to the
            view [m].
        depth_tolerance_m: how far behind the nearest sample of its cell a sample is still
            seen [m] (plus the depth its surface's slope spans across the cell).
        max_incidence_deg: the largest angle between the surface normal and the view ray at
            which a sample is seen [deg].
    """

    cell_m: float = 1.5e-3
    depth_tolerance_m: float = 1.0e-3
    max_incidence_deg: float = 75.0


@dataclass(frozen=True)
class SimulatedScan:
    """Scan points (N, 3) in the table frame [m]; `inlier` (N,) marks points on the surface;
    `pass_index` (N,) the pass each point came from (known to the scanner); `surface_fraction`
    is the fraction of the object's area the scan covers."""

    points: np.ndarray
    inlier: np.ndarray
    pass_index: np.ndarray
    surface_fraction: float


def view_direction(tilt_deg: float) -> np.ndarray:
    """Unit view ray (3,) of a pass looking down, tilted by `tilt_deg` about the table's y
    axis: 0 looks straight down, positive looks towards +x (it sees faces turned to -x)."""
    t = np.deg2rad(tilt_deg)
    return np.array([np.sin(t), 0.0, -np.cos(t)])


def visible_samples(
    p_table: np.ndarray,
    n_table: np.ndarray,
    view: np.ndarray,
    depth_buffer: DepthBuffer,
) -> np.ndarray:
    """Boolean mask (N,) of the samples `p_table` (N, 3) with normals `n_table` (N, 3) seen
    along the unit ray `view` (3,) by the orthographic `depth_buffer`."""
    cell = depth_buffer.cell_m
    cosine = -(n_table @ view)
    facing = cosine >= np.cos(np.deg2rad(depth_buffer.max_incidence_deg))
    u = np.cross(view, [0.0, 1.0, 0.0] if abs(view[1]) < 0.9 else [1.0, 0.0, 0.0])
    u /= np.linalg.norm(u)
    w = np.cross(view, u)
    ij = np.floor(np.stack([p_table @ u, p_table @ w], axis=1) / cell).astype(np.int64)
    _, key = np.unique(ij, axis=0, return_inverse=True)
    depth = p_table @ view
    nearest = np.full(key.max() + 1, np.inf)
    np.minimum.at(nearest, key, depth)
    # A sloped surface spans cell * tan(incidence) in depth within one cell (diagonal).
    slope = np.sqrt(np.clip(1.0 - cosine**2, 0.0, 1.0)) / np.maximum(cosine, 1e-3)
    tolerance = depth_buffer.depth_tolerance_m
    return facing & (depth <= nearest[key] + tolerance + np.sqrt(2.0) * cell * slope)


def simulate_scan(
    vertices_object: np.ndarray,
    faces: np.ndarray,
    T_table_object: np.ndarray,
    tilts_deg: tuple[float, ...],
    count: int,
    errors: ScanErrors,
    rng: np.random.Generator,
    coverage: float | None = None,
    samples: int = 60_000,
    depth_buffer: DepthBuffer = DepthBuffer(),
) -> SimulatedScan:
    """Scan the real surface (`vertices_object` (V, 3) [m], `faces` (F, 3)) placed at
    `T_table_object` (4, 4) with one pass per tilt; `count` points in all, spread over the
    passes in proportion to what each sees through `depth_buffer` (`samples`: how many
    area-uniform samples of the surface it sorts). `coverage` (0, 1] keeps only a patch of
    about that fraction of the object's area around a random seen point (a small scan)."""
    p_object, n_object = sample_surface(
        vertices_object, faces, samples, seed=int(rng.integers(2**31))
    )
    R, t = T_table_object[:3, :3], T_table_object[:3, 3]
    p_table, n_table = p_object @ R.T + t, n_object @ R.T
    seen_by = [
        visible_samples(p_table, n_table, view_direction(a), depth_buffer) for a in tilts_deg
    ]
    seen = np.any(seen_by, axis=0)
    if coverage is not None:
        idx = np.flatnonzero(seen)
        centre = p_table[rng.choice(idx)]
        keep = min(len(idx), max(3, round(coverage * samples)))
        order = np.argsort(np.linalg.norm(p_table[idx] - centre, axis=1))[:keep]
        patch = np.zeros_like(seen)
        patch[idx[order]] = True
        seen_by = [s & patch for s in seen_by]
        seen = patch
    surface_fraction = float(seen.mean())
    chunks = []
    labels = []
    sizes = np.array([s.sum() for s in seen_by], dtype=float)
    shares = np.floor(count * sizes / max(sizes.sum(), 1.0)).astype(int)
    shares[int(np.argmax(sizes))] += count - shares.sum()
    for k, (tilt, mask, share) in enumerate(zip(tilts_deg, seen_by, shares, strict=True)):
        if share <= 0 or not mask.any():
            continue
        view = view_direction(tilt)
        pick = rng.choice(np.flatnonzero(mask), size=share, replace=bool(mask.sum() < share))
        p = p_table[pick] + rng.normal(scale=errors.range_sigma, size=(share, 1)) * view
        p = p + rng.normal(scale=errors.jitter_sigma, size=p.shape)
        dR = Rotation.from_rotvec(rng.normal(scale=errors.pass_rotation_sigma / np.sqrt(3), size=3))
        dt = rng.normal(scale=errors.pass_sigma / np.sqrt(3), size=3)
        centre = p.mean(axis=0)
        chunks.append(dR.apply(p - centre) + centre + dt)
        labels.append(np.full(share, k))
    points, labels_all = np.concatenate(chunks), np.concatenate(labels)
    points, labels_all, inlier = _scan_faults(
        points, labels_all, errors, rng, p_table[seen & (n_table[:, 2] > 0.5)], tilts_deg
    )
    return SimulatedScan(points, inlier, labels_all, surface_fraction)


def _scan_faults(
    points: np.ndarray,
    labels_all: np.ndarray,
    errors: ScanErrors,
    rng: np.random.Generator,
    up_table: np.ndarray,
    tilts_deg: tuple[float, ...],
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The scan's faults on its points (N, 3) labelled by pass (N,): a shiny patch around one
    of the seen upward-facing samples `up_table` (K, 3), a dropout burst, outliers; the
    points, their labels and which are inliers (N',) after them."""
    inlier = np.ones(len(points), dtype=bool)
    if errors.spurious_m > 0.0:  # a shiny patch: its returns too long along the view
        centre = up_table[rng.choice(len(up_table))]
        on = np.linalg.norm(points - centre, axis=1) <= PATCH_RADIUS_M
        views = np.array([view_direction(a) for a in tilts_deg])[labels_all[on]]
        points[on] += errors.spurious_m * views
        inlier[on] = False
    if errors.dropout_burst > 0.0:  # a stretch of one pass returns nothing
        k = int(rng.choice(np.unique(labels_all)))
        y = points[labels_all == k, 1]
        lo, hi = y.min(), y.max()
        width = errors.dropout_burst * (hi - lo)
        start = rng.uniform(lo, hi - width)
        lost = (labels_all == k) & (points[:, 1] >= start) & (points[:, 1] <= start + width)
        points, labels_all, inlier = points[~lost], labels_all[~lost], inlier[~lost]
    n_out = round(errors.outlier_fraction * len(points))
    if n_out:
        lo, hi = points.min(axis=0), points.max(axis=0)
        pad = 0.2 * (hi - lo)
        out = rng.choice(len(points), size=n_out, replace=False)
        points[out] = rng.uniform(lo - pad, hi + pad, size=(n_out, 3))
        inlier[out] = False
    return points, labels_all, inlier
