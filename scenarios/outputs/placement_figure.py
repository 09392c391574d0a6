"""The picture of how a part lies on the table: its mesh at a pose T_table_object on the table
top's outline, seen from above, from the front (along the table's +y) and from the robot
(along +x), with the model's own axes drawn at its origin (x red, y green, z blue)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.collections import PolyCollection
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from models.robot.worktable import TABLE_HALF
from registration import transform_points

#: The light the faces are shaded by (table frame, towards the light), and their colour.
LIGHT = np.array([-0.4, -0.5, 0.77])
SHADE = np.array([0.62, 0.66, 0.74])
AXIS_COLOURS = ("tab:red", "tab:green", "tab:blue")

#: Each view: its title, the table axes drawn right and up, the axis its viewer looks along,
#: and whether the horizontal axis runs right to left (a viewer looking along +x sees +y on
#: its left).
VIEWS = (
    ("from above", 0, 1, np.array([0.0, 0.0, -1.0]), False),
    ("from the front (looking along +y)", 0, 2, np.array([0.0, 1.0, 0.0]), False),
    ("from the robot (looking along +x)", 1, 2, np.array([1.0, 0.0, 0.0]), True),
)
NAMES = "xyz"


def _faces(
    ax: Axes, p_mm: np.ndarray, faces: np.ndarray, right: int, up: int, look: np.ndarray
) -> None:
    """The mesh's faces facing the viewer, farthest first, shaded by LIGHT."""
    tri = p_mm[faces]
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
    front = normals @ look < 0.0
    tri, normals = tri[front], normals[front]
    order = np.argsort(-(tri.mean(axis=1) @ look))  # the farthest along the view first
    light = LIGHT / np.linalg.norm(LIGHT)
    brightness = 0.35 + 0.65 * np.clip(normals[order] @ light, 0.0, 1.0)
    colours = np.clip(brightness[:, None] * SHADE, 0.0, 1.0)
    polygons = tri[order][:, :, [right, up]]
    ax.add_collection(
        PolyCollection(list(polygons), facecolors=colours, edgecolors=colours, linewidths=0.3)
    )


def _axes_arrows(
    ax: Axes, T_table_object: np.ndarray, length_mm: float, right: int, up: int
) -> None:
    """The model's x, y, z axes at its origin, projected into the view."""
    origin = T_table_object[:3, 3] * 1e3
    for k in range(3):
        tip = origin + T_table_object[:3, k] * length_mm
        ax.annotate(
            "", xy=(tip[right], tip[up]), xytext=(origin[right], origin[up]),
            arrowprops={"arrowstyle": "->", "color": AXIS_COLOURS[k], "lw": 1.8},
        )  # fmt: skip
        ax.plot([], [], color=AXIS_COLOURS[k], lw=1.8, label=f"model {NAMES[k]}")


#: The part's points this close above its lowest one are drawn as where it rests [mm].
REST_BAND_MM = 0.5


def _table(ax: Axes, right: int, up: int, lo: np.ndarray, hi: np.ndarray) -> None:
    """The table top: its outline from above (the table frame's origin marked, and the way
    to the arm), its slab (and the top at z = 0) from a side; each view framed on the part."""
    half = np.array(TABLE_HALF) * 1e3
    margin = 0.25 * max(float(np.max(hi - lo)), 10.0)
    if up == 1:
        ax.add_patch(
            Rectangle((-half[0], -half[1]), 2 * half[0], 2 * half[1], fill=False, lw=1.5, ec="0.3")
        )
        ax.plot(0.0, 0.0, marker="+", ms=10, color="0.3")  # the table frame's origin
        width = max(hi[0] - lo[0], hi[1] - lo[1]) + 2 * margin
        centre = (lo[:2] + hi[:2]) / 2
        ax.set_xlim(centre[0] - width / 2, centre[0] + width / 2)
        ax.set_ylim(centre[1] - width / 2, centre[1] + width / 2)
        ax.annotate(
            "to the arm", xy=(centre[0] - width / 2, centre[1] - 0.42 * width),
            xytext=(centre[0] - 0.2 * width, centre[1] - 0.42 * width),
            arrowprops={"arrowstyle": "->", "color": "0.3"}, va="center", fontsize=8, color="0.3",
        )  # fmt: skip
        return
    ax.add_patch(
        Rectangle((-half[right], -2 * half[2]), 2 * half[right], 2 * half[2], fc="0.85", ec="0.3")
    )
    bottom, top = -2 * half[2] - margin / 4, hi[2] + margin
    width = max(hi[right] - lo[right] + 2 * margin, top - bottom)  # at least square
    middle = (lo[right] + hi[right]) / 2
    ax.set_xlim(middle - width / 2, middle + width / 2)
    ax.set_ylim(bottom, top)


def write_placement_figure(
    path: Path,
    vertices_model: np.ndarray,
    faces: np.ndarray,
    T_table_object: np.ndarray,
    title: str,
) -> None:
    """Write the picture of the mesh (vertices (N, 3) [m] in its model frame, faces (M, 3))
    at T_table_object (4, 4) on the table to `path` (PNG), titled `title`."""
    p_mm = transform_points(T_table_object, np.asarray(vertices_model)) * 1e3
    f = np.asarray(faces)
    lo, hi = p_mm.min(axis=0), p_mm.max(axis=0)
    fig = Figure(figsize=(15, 5.2))
    for k, (name, right, up, look, mirrored) in enumerate(VIEWS):
        ax = fig.add_subplot(1, 3, k + 1)
        _table(ax, right, up, lo, hi)
        _faces(ax, p_mm, f, right, up, look)
        rests = p_mm[p_mm[:, 2] <= lo[2] + REST_BAND_MM]
        label = "" if k else f"resting (within {REST_BAND_MM:g} mm of the lowest)"
        ax.plot(rests[:, right], rests[:, up], "o", ms=2.5, color="tab:orange", label=label)
        _axes_arrows(ax, T_table_object, 0.35 * float(np.max(hi - lo)), right, up)
        ax.set_aspect("equal")
        if mirrored:
            ax.invert_xaxis()
        ax.set_xlabel(f"table {NAMES[right]} [mm]")
        ax.set_ylabel(f"table {NAMES[up]} [mm]")
        ax.set_title(name, fontsize=10)
        ax.grid(alpha=0.3)
    fig.axes[0].legend(fontsize=8, loc="upper left")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
