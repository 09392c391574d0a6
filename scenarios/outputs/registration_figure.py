"""registration.png: the registered scan on the model, coloured by residual, seen from above
and from an oblique view; the targets with their achieved error and predicted TRE; the ICP's
RMS per iteration and the residuals' histogram.

The views are orthographic point renderings in the table frame (z up): the model's vertices
shaded by their normal, the scan's points on top of them, both only where they face the
viewer; fast enough for every run, and no OpenGL on the machine that writes them.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib
import numpy as np
import trimesh
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

from models.model import ObjectModel
from registration import MatchResult, invert
from scenarios.outputs.residuals import (
    COLOUR_MAP,
    colour_scale,
    residual_colours,
    signed_residuals,
)

#: Scan points and model vertices drawn at most (random subsamples, seeded).
MAX_POINTS = 20_000
MAX_VERTICES = 25_000


@dataclass(frozen=True)
class TargetMark:
    """A target to mark: its name, position (3,) in the model frame [m], its achieved error
    and its predicted TRE [m] (NaN if unknown)."""

    name: str
    p_model: np.ndarray
    error_m: float
    predicted_tre_m: float


def _basis(view: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    d = view / np.linalg.norm(view)
    ref = np.array([0.0, 1.0, 0.0]) if abs(d[2]) > 0.99 else np.array([0.0, 0.0, 1.0])
    right = np.cross(d, ref)
    right /= np.linalg.norm(right)
    return right, np.cross(right, d), d


def _render(
    ax: Any,
    view: np.ndarray,
    vertices: np.ndarray,
    normals: np.ndarray,
    points: np.ndarray,
    point_normals: np.ndarray,
    colours: np.ndarray,
    marks: list[tuple[str, np.ndarray]],
    title: str,
) -> None:
    right, up, d = _basis(view)
    light = -(d + 0.6 * up - 0.4 * right)
    light /= np.linalg.norm(light)
    front = normals @ d < 0.0
    v = vertices[front]
    shade = 0.35 + 0.6 * np.clip(normals[front] @ light, 0.0, 1.0)
    order = np.argsort(-(v @ d))
    ax.scatter(v[order] @ right, v[order] @ up, s=5.0, c=np.repeat(shade[order, None], 3, 1),
               marker="o", linewidths=0, rasterized=True)  # fmt: skip
    seen = point_normals @ d < 0.0
    p = points[seen]
    order = np.argsort(-(p @ d))
    ax.scatter(p[order] @ right, p[order] @ up, s=2.0, c=colours[seen][order] / 255.0,
               marker="o", linewidths=0, rasterized=True)  # fmt: skip
    for label, x in marks:
        ax.plot(x @ right, x @ up, "k+", ms=9, mew=1.5)
        box = {"boxstyle": "round", "fc": "white", "alpha": 0.8}
        ax.annotate(label, (x @ right, x @ up), xytext=(6, 6), textcoords="offset points",
                    fontsize=7, bbox=box)  # fmt: skip
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_title(title, fontsize=10)


def write_registration_figure(
    path: Path,
    result: MatchResult,
    virtual: ObjectModel,
    points_table: np.ndarray,
    targets: tuple[TargetMark, ...] = (),
) -> None:
    """The figure of `result` (scan points `points_table` (N, 3) in the table frame, matched
    to `virtual`) written to `path` (a PNG) by the caller's atomic writer."""
    T_table_object = invert(result.T_model_data)
    rng = np.random.default_rng(0)
    pts = points_table
    if len(pts) > MAX_POINTS:
        pts = pts[np.sort(rng.choice(len(pts), MAX_POINTS, replace=False))]
    p_model = pts @ result.T_model_data[:3, :3].T + result.T_model_data[:3, 3]
    residuals, n_model = signed_residuals(virtual, p_model)
    scale = colour_scale(result.sigma)
    colours = residual_colours(residuals, scale)
    mesh = trimesh.Trimesh(virtual.mesh.vertices, virtual.mesh.faces, process=False)
    R, t = T_table_object[:3, :3], T_table_object[:3, 3]
    shown = np.arange(len(mesh.vertices))
    if len(shown) > MAX_VERTICES:
        shown = np.sort(rng.choice(len(shown), MAX_VERTICES, replace=False))
    vertices = mesh.vertices[shown] @ R.T + t
    normals = mesh.vertex_normals[shown] @ R.T
    point_normals = n_model @ R.T
    point_normals[~np.isfinite(residuals)] = (0.0, 0.0, -1.0)  # off the model: not drawn
    marks = [
        (
            f"{m.name}\n{m.error_m * 1e3:.2f} / {m.predicted_tre_m * 1e3:.2f} mm",
            R @ m.p_model + t,
        )
        for m in targets
    ]
    fig = Figure(figsize=(15, 6.2), dpi=110)
    grid = fig.add_gridspec(2, 3, width_ratios=(1.25, 1.25, 1.0))
    top = fig.add_subplot(grid[:, 0])
    oblique = fig.add_subplot(grid[:, 1])
    ax_rms = fig.add_subplot(grid[0, 2])
    ax_hist = fig.add_subplot(grid[1, 2])
    _render(top, np.array([0.0, 0.0, -1.0]), vertices, normals, pts, point_normals, colours,
            marks, "from above (table frame)")  # fmt: skip
    _render(oblique, np.array([-1.0, 1.0, -0.8]), vertices, normals, pts, point_normals,
            colours, marks, "oblique")  # fmt: skip
    mapper = matplotlib.cm.ScalarMappable(Normalize(-scale * 1e3, scale * 1e3), COLOUR_MAP)
    bar = fig.colorbar(mapper, cax=fig.add_axes((0.2, 0.07, 0.35, 0.025)),
                       orientation="horizontal")  # fmt: skip
    bar.set_label("scan point to registered model [mm] (inside < 0 < outside; grey: off it)")
    history = np.asarray(result.history) * 1e3
    ax_rms.plot(np.arange(1, len(history) + 1), history, "o-", ms=3)
    ax_rms.set_xlabel("ICP iteration of the best minimum")
    ax_rms.set_ylabel("inlier rms [mm]")
    ax_rms.set_title(
        f"{result.verdict}: rms {result.rms * 1e3:.3f} mm, {result.starts} starts", fontsize=10
    )
    on = np.isfinite(residuals)
    ax_hist.hist(residuals[on] * 1e3, bins=80, range=(-2 * scale * 1e3, 2 * scale * 1e3),
                 color="0.4")  # fmt: skip
    for s in (-result.sigma, result.sigma):
        ax_hist.axvline(s * 1e3, color="tab:red", ls="--", lw=1)
    ax_hist.set_xlabel(f"signed residual [mm] (dashed: sigma {result.sigma * 1e3:.3f} mm)")
    ax_hist.set_ylabel("points")
    if marks:
        fig.suptitle("registered scan on the virtual model; targets: achieved error / "
                     "predicted TRE", fontsize=11)  # fmt: skip
    fig.subplots_adjust(left=0.01, right=0.98, top=0.88, bottom=0.2, wspace=0.1, hspace=0.5)
    fig.savefig(path, format="png")
