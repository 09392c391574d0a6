"""Model assets and generators: arm, table, tools, rack (in `models.robot`); skull phantom,
mechanical parts, the paper's ellipsoid and user meshes as object models.

    >>> from models import load_model, check_model, real_model
    >>> skull, _ = load_model("skull", seed=0)             # virtual model, metres
    >>> real, error = real_model(skull, seed=0)             # + model error (the hidden truth)

The names below are imported on first use (PEP 562), so that `import models.robot` does not
load the mesh libraries.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "ModelError": "models.errors",
    "MeshDataError": "models.errors",
    "MeshFileError": "models.errors",
    "ModelParameterError": "models.errors",
    "UnknownModelError": "models.errors",
    "TriangleMesh": "models.mesh",
    "ObjectModel": "models.model",
    "BurrHole": "models.targets",
    "ProbeLine": "models.targets",
    "OperationFrame": "models.targets",
    "SkullPhantom": "models.skull",
    "make_skull": "models.skull",
    "Part": "models.parts",
    "make_bracket": "models.parts",
    "make_housing": "models.parts",
    "make_lid": "models.parts",
    "ModelErrorSpec": "models.model_error",
    "ModelErrorResult": "models.model_error",
    "apply_model_error": "models.model_error",
    "convex_pieces": "models.convex",
    "AnalyticSurface": "models.surfaces",
    "ellipsoid_surface": "models.surfaces",
    "LoadReport": "models.user_mesh",
    "load_mesh_file": "models.user_mesh",
    "ModelCheck": "models.check",
    "check_model": "models.check",
    "write_mesh": "models.export",
    "builtin_model": "models.registry",
    "builtin_names": "models.registry",
    "load_model": "models.registry",
    "real_model": "models.registry",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(importlib.import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'models' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
