"""Bone from a CT volume: a Hounsfield threshold, the largest connected component with its
internal cavities closed, marching cubes at the voxel spacing (scikit-image), Taubin
smoothing (no shrinkage) and quadric decimation to a target size (fast-simplification).

The check reports how far the final mesh lies from the threshold's isosurface (of the
trilinear grey values: what the smoothing and the decimation moved), its volume and whether
it is watertight.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh
from scipy import ndimage

from models.ct.volume import Volume, VolumeError, lps_mm_to_model
from models.mesh import TriangleMesh

#: Default bone threshold [HU]: above soft tissue and cancellous-bone partial volume, below
#: cortical bone (clinical CT bone thresholds lie between about 200 and 400 HU).
ISO_HU = 300.0
TARGET_FACES = 100_000
SMOOTHING_ITERATIONS = 10


@dataclass(frozen=True)
class BoneCheck:
    """The mesh against the threshold's isosurface: mean and max distance of its vertices
    from it [m]; its volume [m^3] (None if open); watertight; faces; the threshold [HU] and
    the voxel size [mm]."""

    deviation_mean_m: float
    deviation_max_m: float
    volume_m3: float | None
    watertight: bool
    faces: int
    iso_hu: float
    voxel_mm: tuple[float, float, float]


@dataclass(frozen=True, eq=False)
class BoneModel:
    """The bone surface in the volume's model frame (its LPS frame in metres) and its check."""

    mesh: TriangleMesh
    check: BoneCheck


def bone_mask(volume: Volume, iso_hu: float = ISO_HU) -> np.ndarray:
    """Voxels of the largest connected region at or above `iso_hu`, cavities closed. Raises
    VolumeError for a modality that has no Hounsfield units, or a threshold that selects
    nothing or everything."""
    if volume.modality is not None and volume.modality.upper() != "CT":
        raise VolumeError(
            f"{volume.source}: modality {volume.modality}, not CT: a Hounsfield threshold "
            "needs a CT"
        )
    above = volume.data >= iso_hu
    share = float(above.mean())
    if share == 0.0 or share == 1.0:
        raise VolumeError(
            f"{volume.source}: the threshold {iso_hu:g} HU selects "
            f"{'nothing' if share == 0.0 else 'everything'} (values "
            f"{float(volume.data.min()):g} to {float(volume.data.max()):g})"
        )
    labels, count = ndimage.label(above, structure=np.ones((3, 3, 3)))
    bone = above
    if count > 1:
        sizes = np.bincount(labels.ravel())
        sizes[0] = 0
        bone = labels == int(np.argmax(sizes))
    return _fill_cavities(bone)


def _fill_cavities(region: np.ndarray) -> np.ndarray:
    """`region` with every pocket of the rest that does not reach the volume's border
    filled (as scipy's binary_fill_holes, by one labelling of the rest)."""
    rest, _count = ndimage.label(~region)
    faces = [rest[0], rest[-1], rest[:, 0], rest[:, -1], rest[:, :, 0], rest[:, :, -1]]
    border = np.unique(np.concatenate([f.ravel() for f in faces]))
    return ~np.isin(rest, border[border > 0])


def _from_isosurface(
    grey: np.ndarray, iso_hu: float, volume: Volume, offset: np.ndarray, p_lps: np.ndarray
) -> np.ndarray:
    """Distance [mm] of points (N, 3) (LPS) from the threshold's isosurface of the
    trilinear grey values (padded by one voxel, cropped at `offset`): |g - iso| / |grad g|
    at each point, the gradient by central differences, in mm."""
    ijk = volume.lps_to_index(p_lps) - offset + 1.0
    g = ndimage.map_coordinates(grey, ijk.T, order=1, mode="nearest")
    grad = np.empty_like(ijk)
    for axis in range(3):
        step = np.zeros(3)
        step[axis] = 0.5
        ahead = ndimage.map_coordinates(grey, (ijk + step).T, order=1, mode="nearest")
        behind = ndimage.map_coordinates(grey, (ijk - step).T, order=1, mode="nearest")
        grad[:, axis] = ahead - behind
    grad_mm = np.linalg.solve(volume.affine_lps[:3, :3].T, grad.T).T
    return np.abs(g - iso_hu) / np.maximum(np.linalg.norm(grad_mm, axis=1), 1e-9)


def bone_model(
    volume: Volume,
    iso_hu: float = ISO_HU,
    target_faces: int = TARGET_FACES,
    smoothing_iterations: int = SMOOTHING_ITERATIONS,
) -> BoneModel:
    """The bone surface of `volume` at `iso_hu` (see the module's docstring)."""
    import fast_simplification
    from skimage.measure import marching_cubes

    if not target_faces >= 1000:
        raise VolumeError(f"{volume.source}: target_faces must be >= 1000, got {target_faces}")
    mask = bone_mask(volume, iso_hu)
    # Only the bone's box (and two voxels around it) is meshed.
    box = tuple(
        slice(max(int(np.flatnonzero(np.any(mask, axis=other)).min()) - 2, 0),
              int(np.flatnonzero(np.any(mask, axis=other)).max()) + 3)
        for other in ((1, 2), (0, 2), (0, 1))
    )  # fmt: skip
    data, mask = volume.data[box], mask[box]
    offset = np.array([b.start for b in box], dtype=float)
    # The grey values keep the partial volume at the surface; other regions above the
    # threshold are pushed below it, the closed cavities above it; a border of air closes
    # the surface.
    low = min(float(data.min()), iso_hu - 1.0)
    high = max(float(data.max()), iso_hu + 1.0)
    above = data >= iso_hu
    grey = np.where(~mask & above, low, data)
    grey = np.where(mask & ~above, high, grey)
    grey = np.pad(grey, 1, constant_values=low)
    verts, faces, _normals, _values = marching_cubes(grey, level=iso_hu)
    raw = volume.index_to_lps(verts - 1.0 + offset)  # the padding's and the box's offsets
    # scikit-image's faces wind inwards around bright regions in index space; a right-handed
    # voxel frame keeps that in patient space, so they are turned outwards there.
    if np.linalg.det(volume.affine_lps[:3, :3]) > 0:
        faces = faces[:, ::-1]
    mesh = trimesh.Trimesh(raw, faces, process=False)
    if smoothing_iterations > 0:
        trimesh.smoothing.filter_taubin(mesh, lamb=0.5, nu=0.53, iterations=smoothing_iterations)
    if len(mesh.faces) > target_faces:
        v, f = fast_simplification.simplify(
            np.asarray(mesh.vertices, dtype=np.float64),
            np.asarray(mesh.faces, dtype=np.int64),
            target_reduction=1.0 - target_faces / len(mesh.faces),
        )
        mesh = trimesh.Trimesh(v, f, process=False)
    distance = _from_isosurface(grey, iso_hu, volume, offset, np.asarray(mesh.vertices))
    watertight = bool(mesh.is_watertight)
    model_vertices = lps_mm_to_model(mesh.vertices)
    sx, sy, sz = (float(s) for s in volume.spacing_mm)
    check = BoneCheck(
        deviation_mean_m=float(distance.mean()) * 1e-3,
        deviation_max_m=float(distance.max()) * 1e-3,
        volume_m3=float(mesh.volume) * 1e-9 if watertight else None,
        watertight=watertight,
        faces=len(mesh.faces),
        iso_hu=float(iso_hu),
        voxel_mm=(sx, sy, sz),
    )
    return BoneModel(TriangleMesh(model_vertices, np.asarray(mesh.faces)), check)
