"""Model assets and generators: arm, table, tools, rack (in `models.robot`); skull phantom,
mechanical parts, the paper's ellipsoid and user meshes as object models; CT volumes (in
`models.ct`).

    >>> from models.registry import load_model, real_model
    >>> skull, _ = load_model("skull", seed=0)             # virtual model, metres
    >>> real, error = real_model(skull, seed=0)             # + model error (the hidden truth)

Each name is imported from its own module (so that `import models.robot` does not load the
mesh libraries):

- `models.check`: `ModelCheck`, `check_model`
- `models.convex`: `convex_pieces`
- `models.model_errors`: `MeshDataError`, `MeshFileError`, `ModelError`, `ModelParameterError`,
  `UnknownModelError`
- `models.mesh_export`: `write_mesh`
- `models.mesh`: `TriangleMesh`
- `models.model`: `ObjectModel`
- `models.model_error`: `ModelErrorResult`, `ModelErrorSpec`, `apply_model_error`
- `models.parts`: `Part`, `make_bracket`, `make_housing`, `make_lid`
- `models.registry`: `builtin_model`, `builtin_names`, `load_model`, `real_model`
- `models.skull`: `SkullPhantom`, `make_skull`
- `models.surfaces`: `AnalyticSurface`, `ellipsoid_surface`
- `models.targets`: `BurrHole`, `OperationFrame`, `ProbeLine`
- `models.user_mesh`: `LoadReport`, `load_mesh_file`
"""
