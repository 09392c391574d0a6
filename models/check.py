"""A check of a model: what a user looks at before a run or before printing the phantom."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models.mesh import component_labels
from models.model import ObjectModel


@dataclass(frozen=True)
class ModelCheck:
    """Figures of a model. Lengths [m], volumes [m^3]; `volume` and `convex_volume_ratio`
    (total volume of the convex pieces over the solid's) are None for an open mesh."""

    name: str
    source: str
    vertices: int
    faces: int
    watertight: bool
    components: int
    degenerate_faces: int
    extents: tuple[float, float, float]
    volume: float | None
    convex_pieces: int
    convex_volume_ratio: float | None
    operations: tuple[str, ...]
    warnings: tuple[str, ...] = ()

    def rows(self) -> list[tuple[str, str]]:
        """(label, value) pairs for a table, lengths in millimetres."""
        ex, ey, ez = (1e3 * e for e in self.extents)
        rows = [
            ("model", self.name),
            ("source", self.source),
            ("vertices", f"{self.vertices}"),
            ("faces", f"{self.faces}"),
            ("watertight", "yes" if self.watertight else "NO"),
            ("components", f"{self.components}"),
            ("degenerate faces", f"{self.degenerate_faces}"),
            ("extents [mm]", f"{ex:.2f} x {ey:.2f} x {ez:.2f}"),
            ("volume [cm^3]", "n/a (open)" if self.volume is None else f"{self.volume * 1e6:.2f}"),
            ("convex pieces", f"{self.convex_pieces}"),
        ]
        if self.convex_volume_ratio is not None:
            rows.append(("pieces / solid volume", f"{self.convex_volume_ratio:.3f}"))
        if self.operations:
            rows.append(("operations", ", ".join(self.operations)))
        return rows


def check_model(model: ObjectModel, warnings: tuple[str, ...] = ()) -> ModelCheck:
    """Compute the figures of `model`; `warnings` (from loading) are carried along."""
    tm = model.mesh.to_trimesh()
    watertight = bool(tm.is_watertight)
    volume = float(tm.volume) if watertight else None
    ratio = None
    if volume and model.convex_pieces:
        ratio = sum(float(p.to_trimesh().volume) for p in model.convex_pieces) / volume
    area_tol = (1e-9 * float(tm.extents.max())) ** 2
    extents = np.ptp(np.asarray(model.mesh.vertices), axis=0)
    return ModelCheck(
        name=model.name,
        source=model.source,
        vertices=len(model.mesh.vertices),
        faces=len(model.mesh.faces),
        watertight=watertight,
        components=int(component_labels(tm).max()) + 1,
        degenerate_faces=int((tm.area_faces <= area_tol).sum()),
        extents=(float(extents[0]), float(extents[1]), float(extents[2])),
        volume=volume,
        convex_pieces=len(model.convex_pieces),
        convex_volume_ratio=ratio,
        operations=tuple(h.name for h in model.burr_holes) + tuple(f.name for f in model.frames),
        warnings=tuple(warnings),
    )
