"""The convex pieces work as MuJoCo contact geometry: each model, dropped on a floor, comes to
rest with its exact surface touching the floor (neither sunk in nor floating)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from models.registry import builtin_model


def _drop(name: str) -> tuple[float, float]:
    """Lowest point of the exact mesh [m] and speed [m/s, rad/s] after 3 s on a floor."""
    model = builtin_model(name)
    spec = mujoco.MjSpec()
    spec.option.timestep = 0.002
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[1.0, 1.0, 0.1])
    body = spec.worldbody.add_body(name="object", pos=[0.0, 0.0, 0.25])
    body.add_freejoint()
    for i, piece in enumerate(model.convex_pieces):
        spec.add_mesh(
            name=f"piece{i}",
            uservert=np.asarray(piece.vertices).ravel().tolist(),
            userface=np.asarray(piece.faces).ravel().tolist(),
        )
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"piece{i}", density=1200.0)
    compiled = spec.compile()
    data = mujoco.MjData(compiled)
    for _ in range(1500):
        mujoco.mj_step(compiled, data)
    body_id = compiled.body("object").id
    R_world_object = data.xmat[body_id].reshape(3, 3)
    p_world = np.asarray(model.mesh.vertices) @ R_world_object.T + data.xpos[body_id]
    return float(p_world[:, 2].min()), float(np.linalg.norm(data.qvel))


@pytest.mark.parametrize("name", ["skull", "bracket", "housing", "lid", "ellipsoid"])
def test_model_rests_on_the_floor_on_its_convex_pieces(name) -> None:
    lowest, speed = _drop(name)
    assert speed < 1e-3  # at rest
    assert -1e-3 < lowest < 0.5e-3  # touching: soft contact and hull facets, under 1 mm
