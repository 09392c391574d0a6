"""Surface matching on numpy arrays: robust multi-start ICP (points, meshes, surfaces)."""
