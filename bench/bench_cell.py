"""Benchmark of the cell: physics real-time factor, laser rays per second, IK solves per second.

Ours vs a peer on the same scene in the same run:
- physics: the controller's joint moves (one set-point write per step) between home and TCP
  poses above the table, clear of the table, the rack and the check station, vs raw
  `mj_step` with `nstep` (no Python per step) on the same model and the same number of steps;
- laser: `Controller.read_laser()` (rays, range limits, grazing dropout, noise, joint stamp)
  vs one raw `mj_multiRay` call with the same origin, directions and geom groups, the laser
  15 cm above a 20k-triangle ball on the table (every ray returns from it; the tool fetched
  through home, as the jobs fetch it);
- IK: Pinocchio damped least squares, from home and from a nearby seed.

    python bench/bench_cell.py [--short]

--short: two moves, the laser read 20 times, 30 IK targets (a few seconds).
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass

import mujoco
import numpy as np
import trimesh
from rich.console import Console
from rich.table import Table

from cell import FixedMesh, LaserConfig, nominal_kinematics
from cell.scene_builder import RAY_GROUPS
from cell.sim import CellConfig, make_cell
from models.robot import Q_HOME
from registration.rigid import make_T
from scenarios.program.tool_change import change_tool_safely

R_DOWN = np.diag([1.0, -1.0, -1.0])
#: Flange positions [m] in the base frame, pointing down, 25-40 cm above the table top
#: (z = 0.4 m; the table 0.8 x 0.6 m about x = 1.15 m): clear of everything in the cell.
P_OVER_TABLE = (
    (0.9, -0.3, 0.8),
    (1.3, 0.3, 0.65),
    (1.15, 0.0, 0.75),
    (1.0, 0.25, 0.7),
    (1.3, -0.25, 0.7),
    (1.15, 0.1, 0.8),
)
#: The laser's TCP above the ball's top (z = 0.6 m) [m]: within its 0.05-0.6 m range, and
#: the 0.6 rad fan (4.6 cm either side) within the ball's 10 cm radius.
P_LASER = (1.15, 0.02, 0.75)


@dataclass(frozen=True)
class Sizes:
    """How much each part of the benchmark runs."""

    poses: int = len(P_OVER_TABLE)
    rounds: int = 3
    laser_repeats: int = 200
    ik_targets: int = 300


def bench_physics(poses: int, rounds: int) -> tuple[float, float, float]:
    """Real-time factor of the controller's moves (`rounds` times from home through `poses`
    poses above the table and back) and of raw mj_step over as many steps; and the simulated
    seconds."""
    controller, truth = make_cell(CellConfig(seed=0))
    sim = truth.simulation
    targets = [make_T(R_DOWN, np.array(p)) for p in P_OVER_TABLE[:poses]]
    t0, s0 = time.perf_counter(), sim.time
    for _ in range(rounds):
        for T in targets:
            controller.move_tcp(T, settle_s=0.0)
        controller.move_joints(controller.q_home, settle_s=0.0)
    ours = (sim.time - s0) / (time.perf_counter() - t0)
    simulated = sim.time - s0
    n = round(simulated / sim.dt)
    t0, s0 = time.perf_counter(), sim.time
    mujoco.mj_step(sim.model, sim.data, nstep=n)
    raw = (sim.time - s0) / (time.perf_counter() - t0)
    return ours, raw, simulated


def bench_laser(n_rays: int, repeats: int) -> tuple[float, float, float]:
    """Rays per second of read_laser and of raw mj_multiRay; the share of rays that return."""
    ball = trimesh.creation.icosphere(subdivisions=5, radius=0.1)  # 20480 triangles
    T_table_ball = make_T(np.eye(3), np.array([0.0, 0.0, 0.1]))
    config = CellConfig(
        seed=0,
        laser=LaserConfig(n_rays=n_rays),
        fixtures=(FixedMesh("ball", ball.vertices, ball.faces, T_table_ball),),
    )
    controller, truth = make_cell(config)
    change_tool_safely(controller, "laser")
    controller.move_tcp(make_T(R_DOWN, np.array(P_LASER)))
    returned = float(controller.read_laser().valid.mean())
    if returned < 0.99:
        raise RuntimeError(f"only {returned:.0%} of the laser's rays return from the ball")
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
    return ours, raw, returned


def bench_ik(n: int) -> tuple[float, float]:
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
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--short", action="store_true", help="a few seconds: fewer of each")
    args = parser.parse_args()
    sizes = Sizes(poses=1, rounds=1, laser_repeats=20, ik_targets=30) if args.short else Sizes()
    table = Table(title="twincell cell benchmark (one core)")
    table.add_column("measure")
    table.add_column("ours", justify="right")
    table.add_column("peer", justify="right")
    table.add_column("ours / peer", justify="right")
    ours, raw, simulated = bench_physics(sizes.poses, sizes.rounds)
    table.add_row(
        f"physics, arm moving {simulated:.1f} s [x real time]",
        f"{ours:.1f}",
        f"{raw:.1f} (raw mj_step)",
        f"{ours / raw:.2f}",
    )
    for n_rays in (256, 1024):
        ours, raw, returned = bench_laser(n_rays, sizes.laser_repeats)
        table.add_row(
            f"laser rays/s, {n_rays} rays, 20k-triangle object ({returned:.0%} return)",
            f"{ours:,.0f}",
            f"{raw:,.0f} (raw mj_multiRay)",
            f"{ours / raw:.2f}",
        )
    far, near = bench_ik(sizes.ik_targets)
    table.add_row(
        f"IK solves/s, {sizes.ik_targets} targets, seeded from home", f"{far:,.0f}", "", ""
    )
    table.add_row("IK solves/s, seeded 0.05 rad away", f"{near:,.0f}", "", "")
    Console().print(table)


if __name__ == "__main__":
    main()
