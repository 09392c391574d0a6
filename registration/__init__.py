"""Surface matching on numpy arrays: robust multi-start ICP against points, meshes and parametric surfaces."""
