"""The object model value: the exact surface, its convex contact pieces and its operations."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models.mesh import TriangleMesh
from models.model_errors import MeshDataError, UnknownModelError
from models.surfaces import AnalyticSurface
from models.targets import BurrHole, OperationFrame, ProbeLine


@dataclass(frozen=True, eq=False)
class ObjectModel:
    """An object of the cell as the planner knows it (virtual) or as it is (real).

    `mesh` is the exact surface in the object's model frame [m]: rays and registration use
    it. `convex_pieces` are closed convex meshes [m] for MuJoCo contacts (concave objects have
    several). `burr_holes` (skull) and `frames` (parts) are the operation targets in the model
    frame; `probe_lines` are the IR probe lines across a flat part's edges (2D adjusting).
    `points` (K, 3) [m] is a reference point set of the model (the paper's 55 points
    on the ellipsoid), `surface` its analytic surface r(u, v) where it has one. `source` says
    where the model came from ("built-in", a file path, "... + model error").
    """

    name: str
    mesh: TriangleMesh
    convex_pieces: tuple[TriangleMesh, ...]
    burr_holes: tuple[BurrHole, ...] = ()
    frames: tuple[OperationFrame, ...] = ()
    probe_lines: tuple[ProbeLine, ...] = ()
    points: np.ndarray | None = None
    surface: AnalyticSurface | None = None
    source: str = "built-in"

    def __post_init__(self) -> None:
        if self.points is not None:
            points = np.array(self.points, dtype=float)
            if points.ndim != 2 or points.shape[1] != 3 or not np.isfinite(points).all():
                raise MeshDataError(f"points must be a finite (K, 3) array, got {points.shape}")
            points.setflags(write=False)
            object.__setattr__(self, "points", points)

    def frame(self, name: str) -> OperationFrame:
        """The operation frame called `name`; raises UnknownModelError listing the valid names."""
        for frame in self.frames:
            if frame.name == name:
                return frame
        names = [f.name for f in self.frames]
        raise UnknownModelError(
            f"model {self.name!r} has no operation frame {name!r}; its frames are {names}"
        )

    def burr_hole(self, name: str) -> BurrHole:
        """The burr hole called `name`; raises UnknownModelError listing the valid names."""
        for hole in self.burr_holes:
            if hole.name == name:
                return hole
        names = [h.name for h in self.burr_holes]
        raise UnknownModelError(
            f"model {self.name!r} has no burr hole {name!r}; its burr holes are {names}"
        )
