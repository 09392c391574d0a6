"""Benchmark of the cell: physics real-time factor, laser rays per second, IK solves per second.

Ours vs a peer on the same scene in the same run:
- physics: the controller's joint moves (one set-point write per step) vs raw `mj_step`
  with `nstep` (no Python per step) on the same model and the same number of steps;
- laser: `Controller.read_laser()` (rays, range limits, grazing dropout, noise, joint stamp)
  vs one raw `mj_multiRay` call with the same origin, directions and geom groups;
- IK: Pinocchio damped least squares, from home and from a nearby seed.

Run: python bench/bench_cell.py
"""

from __future__ import annotations

import time

import mujoco
import numpy as np
import trimesh
from rich.console import Console
from rich.table import Table

from cell import FixedMesh, LaserConfig, nominal_kinematics
from cell.scene import RAY_GROUPS
from cell.sim import CellConfig, make_cell
from models.robot import Q_HOME
from registration.rigid import make_T

R_DOWN = np.diag([1.0, -1.0, -1.0])


def bench_physics() -> tuple[float, float]:
    controller, truth = make_cell(CellConfig(seed=0))
    sim = truth.simulation
    rng = np.random.default_rng(0)
    kin = controller.kinematics
    targets = [np.clip(Q_HOME + rng.uniform(-0.8, 0.8, 6), kin.lower, kin.upper) for _ in range(8)]
    t0, s0 = time.perf_counter(), sim.time
    for q in targets:
        controller.move_joints(q, settle_s=0.0)
    ours = (sim.time - s0) / (time.perf_counter() - t0)
    n = round((sim.time - s0) / sim.dt)
    t0, s0 = time.perf_counter(), sim.time
    mujoco.mj_step(sim.model, sim.data, nstep=n)
    raw = (sim.time - s0) / (time.perf_counter() - t0)
    return ours, raw


def bench_laser(n_rays: int, repeats: int = 200) -> tuple[float, float]:
    ball = trimesh.creation.icosphere(subdivisions=5, radius=0.1)  # 20480 triangles
    T = make_T(np.eye(3), np.array([0.0, 0.0, 0.1]))
    config = CellConfig(
        seed=0,
        laser=LaserConfig(n_rays=n_rays),
        fixtures=(FixedMesh("ball", ball.vertices, ball.faces, T),),
    )
    controller, truth = make_cell(config)
    controller.change_tool("laser")
    controller.move_tcp(make_T(R_DOWN, np.array([1.15, 0.02, 0.6])))
    t0 = time.perf_counter()
    for _ in range(repeats):
        controller.read_laser()
    ours = repeats * n_rays / (time.perf_counter() - t0)
    sim = truth.simulation
    site = sim.tcp_site["laser"]
    vec = (controller.laser_directions_tcp @ sim.data.site_xmat[site].reshape(3, 3).T).ravel()
    geomid = np.zeros(n_rays, dtype=np.int32)
    dist = np.zeros(n_rays)
    normal = np.zeros(3 * n_rays)
    pnt = sim.data.site_xpos[site].copy()
    t0 = time.perf_counter()
    for _ in range(repeats):
        mujoco.mj_multiRay(
            sim.model, sim.data, pnt, vec, RAY_GROUPS, 1, -1, geomid, dist, normal, n_rays, 0.6
        )
    raw = repeats * n_rays / (time.perf_counter() - t0)
    return ours, raw


def bench_ik(n: int = 300) -> tuple[float, float]:
    kin = nominal_kinematics()
    rng = np.random.default_rng(0)
    qs = [kin.random_configuration(rng, margin=0.05) for _ in range(n)]
    targets = [kin.fk(q) for q in qs]
    t0 = time.perf_counter()
    for T in targets:
        kin.ik(T, Q_HOME)
    far = n / (time.perf_counter() - t0)
    t0 = time.perf_counter()
    for q, T in zip(qs, targets, strict=True):
        kin.ik(T, q + 0.05)
    near = n / (time.perf_counter() - t0)
    return far, near


def main() -> None:
    table = Table(title="twincell cell benchmark (one core)")
    table.add_column("measure")
    table.add_column("ours", justify="right")
    table.add_column("peer", justify="right")
    table.add_column("ours / peer", justify="right")
    ours, raw = bench_physics()
    table.add_row(
        "physics, arm moving [x real time]",
        f"{ours:.1f}",
        f"{raw:.1f} (raw mj_step)",
        f"{ours / raw:.2f}",
    )
    for n_rays in (256, 1024):
        ours, raw = bench_laser(n_rays)
        table.add_row(
            f"laser rays/s, {n_rays} rays, 20k-triangle object",
            f"{ours:,.0f}",
            f"{raw:,.0f} (raw mj_multiRay)",
            f"{ours / raw:.2f}",
        )
    far, near = bench_ik()
    table.add_row("IK solves/s, seeded from home", f"{far:,.0f}", "", "")
    table.add_row("IK solves/s, seeded 0.05 rad away", f"{near:,.0f}", "", "")
    Console().print(table)


if __name__ == "__main__":
    main()
