"""Scan points against the registered model: signed residuals and their colours, shared by
the recording and the registration figure."""

from __future__ import annotations

import matplotlib
import numpy as np

from models.model import ObjectModel
from registration import MeshModel

#: The colour scale's steps [m]; the smallest that holds 2 sigma of the fit is used.
SCALES_M = (0.02e-3, 0.05e-3, 0.1e-3, 0.2e-3, 0.3e-3, 0.5e-3, 1e-3, 2e-3, 5e-3)
#: Farther than this from the model a point is off it (grey) [m].
OFF_MODEL_M = 5e-3
OFF_MODEL_RGBA = (140, 140, 140, 255)


def signed_residuals(virtual: ObjectModel, p_model: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Signed distance (N,) [m] of points (N, 3) in the model frame from the model's surface
    (its exact closest point; outside > 0), inf beyond OFF_MODEL_M of it; and the surface's
    normal (N, 3) there (zero where off)."""
    shape = MeshModel(virtual.mesh.vertices, virtual.mesh.faces)
    closest = shape.closest_within(np.asarray(p_model, dtype=float), OFF_MODEL_M)
    found = np.ones(len(p_model), dtype=bool) if closest.found is None else closest.found
    normals = np.zeros((len(p_model), 3))
    out = np.full(len(p_model), np.inf)
    if closest.normals is not None:
        normals[found] = closest.normals[found]
    side = np.sign(np.einsum("ij,ij->i", p_model - closest.points, normals))
    out[found] = np.where(side[found] < 0, -1.0, 1.0) * closest.distances[found]
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
