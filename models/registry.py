"""Built-in models by name, user mesh files by path, and the real entity of either.

>>> model = builtin_model("skull", seed=0)            # the virtual model
>>> real, error = real_model(model, seed=7)            # + CT-like model error (hidden truth)
>>> model, warnings = load_model("part.stl", units="mm")
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from functools import lru_cache
from pathlib import Path

import numpy as np
import trimesh

from models import ellipsoid
from models.cache import CACHED, cached
from models.convex import convex_pieces
from models.mesh import TriangleMesh
from models.model import ObjectModel
from models.model_error import ModelErrorResult, ModelErrorSpec, apply_model_error
from models.model_errors import ModelParameterError, UnknownModelError
from models.parts import Part, make_bracket, make_housing, make_lid
from models.skull import make_skull
from models.surfaces import ellipsoid_radii, ellipsoid_surface
from models.targets import BurrHole, OperationFrame
from models.units import unit_scale
from models.user_mesh import MESH_SUFFIXES, load_mesh_file


def _skull(seed: int) -> ObjectModel:
    phantom = make_skull(seed)
    return ObjectModel(
        name="skull",
        mesh=phantom.mesh,
        convex_pieces=convex_pieces(phantom.mesh, seed=seed),
        burr_holes=phantom.burr_holes,
        source=f"built-in (seed {seed})",
    )


def _part(make: Callable[[], Part]) -> Callable[[int], ObjectModel]:
    def build(seed: int) -> ObjectModel:
        part = make()
        return ObjectModel(
            part.name,
            part.mesh,
            part.convex_pieces,
            frames=part.frames,
            probe_lines=part.probe_lines,
        )

    return build


def _ellipsoid(seed: int) -> ObjectModel:
    """The paper's ellipsoid, 200 x 120 x 80 mm: an icosphere (20480 triangles) scaled onto
    it, so that every vertex lies on the analytic surface; the 55 model points; r(u, v)."""
    radii = np.array(ellipsoid_radii())
    sphere = trimesh.creation.icosphere(subdivisions=5)
    mesh = TriangleMesh(np.asarray(sphere.vertices) * radii, sphere.faces)
    return ObjectModel(
        name="ellipsoid",
        mesh=mesh,
        convex_pieces=convex_pieces(mesh),
        points=ellipsoid.model_points(55, radii=(radii[0], radii[1], radii[2])),
        surface=ellipsoid_surface(),
    )


_BUILDERS: dict[str, Callable[[int], ObjectModel]] = {
    "skull": _skull,  # seconds to build: kept on disk (models.cache.CACHED)
    "bracket": _part(make_bracket),
    "housing": _part(make_housing),
    "lid": _part(make_lid),
    "ellipsoid": _ellipsoid,
}


def builtin_names() -> tuple[str, ...]:
    """Names of the built-in models."""
    return tuple(_BUILDERS)


def _check_seed(seed: int) -> int:
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ModelParameterError(f"seed must be a non-negative integer, got {seed!r}")
    return int(seed)


@lru_cache(maxsize=16)
def _cached(name: str, seed: int, use_cache: bool) -> ObjectModel:
    build = _BUILDERS[name]
    return cached(name, seed, build, use_cache) if name in CACHED else build(seed)


def builtin_model(name: str, seed: int = 0, use_cache: bool = True) -> ObjectModel:
    """The built-in model `name` (see `builtin_names()`); `seed` shapes the skull (the others
    do not depend on it). Results are cached in memory; the values are immutable. The skull
    is kept on disk too (models.cache), unless `use_cache` is False."""
    if name not in _BUILDERS:
        raise UnknownModelError(
            f"unknown model {name!r}; built-in models are {list(_BUILDERS)}, or give a mesh file "
            f"({', '.join(MESH_SUFFIXES)})"
        )
    return _cached(name, _check_seed(seed), use_cache)


def _displaced_hole(hole: BurrHole, field: Callable[[np.ndarray], np.ndarray]) -> BurrHole:
    p_virtual = np.array([hole.p_entry, hole.p_target])
    p_entry, p_target = p_virtual + field(p_virtual)
    axis = p_target - p_entry
    return BurrHole(hole.name, p_entry, axis, float(np.linalg.norm(axis)))


def _displaced_frame(
    frame: OperationFrame, field: Callable[[np.ndarray], np.ndarray]
) -> OperationFrame:
    T = np.array(frame.T_part_frame)
    T[:3, 3] += field(T[None, :3, 3])[0]
    return OperationFrame(frame.name, frame.kind, T)


def real_model(
    model: ObjectModel, spec: ModelErrorSpec | None = None, seed: int = 0
) -> tuple[ObjectModel, ModelErrorResult]:
    """The real entity of `model`: its surface with the model error `spec` (seeded), the
    contact pieces and the operation targets moved by the error's smooth deformation.

    The planner never sees this: it is the simulated truth (cell and evaluator only).
    """
    spec = spec or ModelErrorSpec()
    error = apply_model_error(model.mesh, spec, _check_seed(seed))
    pieces = tuple(
        TriangleMesh(np.asarray(p.vertices) + error.field(np.asarray(p.vertices)), p.faces)
        for p in model.convex_pieces
    )
    real = replace(
        model,
        mesh=error.mesh,
        convex_pieces=pieces,
        burr_holes=tuple(_displaced_hole(h, error.field) for h in model.burr_holes),
        frames=tuple(_displaced_frame(f, error.field) for f in model.frames),
        points=None if model.points is None else model.points + error.field(model.points),
        surface=None,  # the real entity has no exact analytic form
        source=f"{model.source} + model error ({spec.total_rms * 1e3:.2f} mm RMS, seed {seed})",
    )
    return real, error


def load_model(
    name_or_path: str | Path,
    *,
    real: bool = False,
    seed: int = 0,
    units: str | float = "mm",
    spec: ModelErrorSpec | None = None,
    use_cache: bool = True,
    units_option: str = "--units",
) -> tuple[ObjectModel, tuple[str, ...]]:
    """A built-in model by name or a user mesh file by path (in `units`, given by the user as
    `units_option`: an option or a configuration key), optionally as its real entity
    (`real=True`, model error seeded by `seed`). Returns the model and the warnings found
    while loading. `use_cache`: see `builtin_model`."""
    unit_scale(units)  # refuse bad units even when a built-in model does not need them
    warnings: tuple[str, ...] = ()
    name = str(name_or_path)
    if name in _BUILDERS:
        model = builtin_model(name, seed, use_cache)
    elif Path(name).suffix or Path(name).exists() or "/" in name:
        model, report = load_mesh_file(name, units, units_option=units_option)
        warnings = report.warnings
    else:
        raise UnknownModelError(
            f"unknown model {name!r}; built-in models are {list(_BUILDERS)}, or give a mesh file "
            f"({', '.join(MESH_SUFFIXES)})"
        )
    if real:
        model, _ = real_model(model, spec, seed)
    return model, warnings
