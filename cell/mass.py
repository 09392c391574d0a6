"""Mass properties of a solid bounded by a closed triangle mesh (uniform density).

Volume, centre of mass and inertia come from the divergence theorem over the triangles
(trimesh's `mass_properties`). A loose object's body in the cell takes them as its inertial.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from cell.cell_errors import CellConfigError


@dataclass(frozen=True, eq=False)
class MassProperties:
    """A rigid body's inertial data in its object frame.

    Attributes:
        volume_m3: enclosed volume [m^3].
        mass_kg: mass [kg].
        p_object_com: (3,) centre of mass in the object frame [m].
        I_com: (3, 3) inertia tensor about the centre of mass, object axes [kg m^2].
    """

    volume_m3: float
    mass_kg: float
    p_object_com: np.ndarray
    I_com: np.ndarray

    def fullinertia(self) -> list[float]:
        """MuJoCo's `fullinertia` order: [ixx, iyy, izz, ixy, ixz, iyz] [kg m^2]."""
        inertia = self.I_com
        return [
            float(inertia[0, 0]),
            float(inertia[1, 1]),
            float(inertia[2, 2]),
            float(inertia[0, 1]),
            float(inertia[0, 2]),
            float(inertia[1, 2]),
        ]


def mesh_mass_properties(
    vertices: np.ndarray,
    faces: np.ndarray,
    density_kg_m3: float,
    mass_kg: float | None = None,
) -> MassProperties:
    """Mass properties of the solid inside the closed mesh `vertices` (N, 3) [m], `faces`
    (M, 3), outward normals. Mass is `mass_kg` if given (density then = mass / volume), else
    volume x `density_kg_m3` [kg/m^3]. Raises CellConfigError if the enclosed volume is not
    positive (an open or inside-out mesh)."""
    mesh = trimesh.Trimesh(np.asarray(vertices, float), np.asarray(faces), process=False)
    props = mesh.mass_properties  # density 1: mass = volume
    volume = float(props.volume)
    if not (np.isfinite(volume) and volume > 1e-12):
        raise CellConfigError(
            f"the mesh encloses a volume of {volume!r} m^3: a loose object needs a closed "
            "surface with outward normals to have a mass"
        )
    density = density_kg_m3 if mass_kg is None else mass_kg / volume
    inertia = np.asarray(props.inertia, float) * density
    return MassProperties(
        volume, volume * density, np.asarray(props.center_mass, float).copy(), inertia
    )
