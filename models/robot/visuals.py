"""The built-in arm's looks: the ABB IRB 2400's visual meshes (visuals/irb2400/README.md for
their source and licence), for the recording. Physics and kinematics never use them.

Each mesh is in its URDF link frame: at the zero pose parallel to the base, its origin at
`origin_zero` [m]; a viewer places it on a body of the arm by that body's pose at the zero
pose (T_body_mesh = inv(T_base_body(0)) @ T_base_link(0)).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

FOLDER = Path(__file__).parent / "visuals" / "irb2400"
ORANGE = (188, 89, 41, 255)
DARK = (40, 40, 44, 255)


@dataclass(frozen=True, eq=False)
class LinkVisual:
    """One link's mesh: the arm's body it rides on, vertices (V, 3) [m] and faces (F, 3) in
    the link frame, the link frame's origin at the zero pose (3,) [m], RGBA 0-255."""

    body: str
    vertices: np.ndarray
    faces: np.ndarray
    origin_zero: np.ndarray
    rgba: tuple[int, int, int, int]


#: (file, body of the arm, URDF joint origin at the zero pose [m], colour): IRB 2400.
_LINKS = (
    ("base_link", "base", (0.0, 0.0, 0.0), DARK),
    ("link_1", "link1", (0.0, 0.0, 0.0), ORANGE),
    ("link_2", "link2", (0.1, 0.0, 0.615), ORANGE),
    ("link_3", "link3", (0.1, 0.0, 1.32), ORANGE),
    ("link_4", "link4", (0.358, 0.0, 1.455), ORANGE),
    ("link_5", "link5", (0.855, 0.0, 1.455), ORANGE),
    ("link_6", "link6", (0.94, 0.0, 1.455), DARK),
)


@cache
def irb2400_visuals() -> tuple[LinkVisual, ...]:
    """The IRB 2400's link meshes, read once."""
    out = []
    for name, body, origin, rgba in _LINKS:
        mesh: Any = trimesh.load(FOLDER / f"{name}.stl", force="mesh")  # a Trimesh
        out.append(
            LinkVisual(
                body,
                np.asarray(mesh.vertices, dtype=float),
                np.asarray(mesh.faces, dtype=np.int64),
                np.array(origin),
                rgba,
            )
        )
    return tuple(out)
