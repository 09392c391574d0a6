"""Scan points against the registered model: signed residuals and their colours, shared by
the recording and the registration figure."""

from __future__ import annotations

import matplotlib
import numpy as np
import trimesh
from scipy.spatial import cKDTree

from models import ObjectModel

#: The colour scale's steps [m]; the smallest that holds 2 sigma of the fit is used.
SCALES_M = (0.1e-3, 0.2e-3, 0.3e-3, 0.5e-3, 1e-3, 2e-3, 5e-3)
#: Farther than this from the model a point is off it (grey) [m].
OFF_MODEL_M = 5e-3
OFF_MODEL_RGBA = (140, 140, 140, 255)


def signed_residuals(virtual: ObjectModel, p_model: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Signed distance (N,) [m] of points (N, 3) in the model frame from the model's surface,
    along the normal of the nearest vertex (outside > 0; the vertices are far denser than
    the residuals matter), inf beyond OFF_MODEL_M of every vertex; and that normal (N, 3)."""
    mesh = trimesh.Trimesh(virtual.mesh.vertices, virtual.mesh.faces, process=False)
    distance, nearest = cKDTree(mesh.vertices).query(p_model, distance_upper_bound=OFF_MODEL_M)
    out = np.full(len(p_model), np.inf)
    normals = np.zeros((len(p_model), 3))
    ok = np.isfinite(distance)
    normals[ok] = mesh.vertex_normals[nearest[ok]]
    out[ok] = np.einsum("ij,ij->i", p_model[ok] - mesh.vertices[nearest[ok]], normals[ok])
    return out, normals


#: The colour map of residuals: a perceptual rainbow, whose middle (green) stands out on
#: a grey model where a diverging map's white would not.
COLOUR_MAP = "turbo"


def colour_scale(sigma_m: float) -> float:
    """The colour scale's half range [m]: 2 sigma of the fit, rounded up to a step."""
    return next((s for s in SCALES_M if s >= 2.0 * sigma_m), SCALES_M[-1])


def residual_colours(residuals: np.ndarray, scale_m: float) -> np.ndarray:
    """(N, 4) uint8: blue inside, green on, red outside the model, saturated at `scale_m`;
    grey off the model."""
    x = np.clip(np.nan_to_num(residuals / scale_m, posinf=0.0) * 0.5 + 0.5, 0.0, 1.0)
    rgba = (matplotlib.colormaps[COLOUR_MAP](x) * 255).astype(np.uint8)
    rgba[~np.isfinite(residuals)] = OFF_MODEL_RGBA
    return rgba
