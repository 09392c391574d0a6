"""The cell's range sensors: the laser line scanner and the IR proximity sensor.

Both cast rays with MuJoCo from their TCP site. Rays ignore the arm (geom groups 2, 3), the
tools (group 4) and contact-only pieces (group 5): a sensor never sees the robot or itself.
A ray that hits nothing, or lands outside the range limits, or too grazing, is "no return"
(NaN), never a point.
"""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np

from cell.layout import IRConfig, LaserConfig
from cell.scene_builder import RAY_GROUPS
from cell.sim.faults import FaultInjector

#: Radius of a reflective patch that returns spurious ranges (fault laser_spurious) [m].
PATCH_RADIUS_M = 0.01


class LaserScanner:
    """A fan of rays from one origin (the laser's optical frame, its TCP site); range limits,
    a range scale error, noise, grazing dropout."""

    def __init__(
        self,
        model: mujoco.MjModel,
        site: int,
        config: LaserConfig,
        rng: np.random.Generator,
        scale: float = 0.0,
    ) -> None:
        self.model = model
        self.site = site
        self.config = config
        self.rng = rng
        self.scale = scale  # relative range scale error (truth)
        self.dirs_tcp = config.directions_tcp()
        n = config.n_rays
        self._geomid = np.zeros(n, dtype=np.int32)
        self._dist = np.zeros(n)
        self._normal = np.zeros(3 * n)
        self._cos_max = float(np.cos(config.max_incidence_rad))
        #: A witness of every line: (data, origin (3,), directions (n, 3), ranges (n,) as
        #: measured, NaN = no return), all in the world frame. For a recording; None: none.
        self.witness: Callable[[mujoco.MjData, np.ndarray, np.ndarray, np.ndarray], None] | None
        self.witness = None
        self.faults: FaultInjector | None = None
        #: The object a spurious patch lies on: its geom and (N, 3) candidate centres in its
        #: frame.
        self.patch_object: tuple[int, np.ndarray] | None = None
        self._burst: tuple[float, float] | None = None  # (start, end) [s]
        self._patch: np.ndarray | None = None  # centre in the object's geom frame

    def _faulty(self, data: mujoco.MjData, d: np.ndarray, vec: np.ndarray) -> None:
        """The laser's faults on one line's ranges `d` (n_rays,), in place."""
        faults = self.faults
        if faults is None:
            return
        if faults.armed("laser_dropout_burst") is not None and self._burst is None:
            fault = faults.faults["laser_dropout_burst"]
            start = data.time + float(faults.rng.uniform(0.2, 1.5))
            self._burst = (start, start + fault.amount)
        if self._burst is not None and self._burst[0] <= data.time <= self._burst[1]:
            if "laser_dropout_burst" not in faults.fired:
                faults.fire(
                    "laser_dropout_burst",
                    f"no returns for {self._burst[1] - self._burst[0]:g} s",
                )
            d[:] = np.nan
            return
        spurious = faults.active("laser_spurious")
        if spurious is None or self.patch_object is None:
            return
        geom, vertices = self.patch_object
        if self._patch is None:  # drawn once among the candidates
            self._patch = vertices[int(faults.rng.integers(len(vertices)))]
        R = data.geom_xmat[geom].reshape(3, 3)
        centre = data.geom_xpos[geom] + R @ self._patch
        hit = data.site_xpos[self.site] + d[:, None] * vec
        on = np.linalg.norm(hit - centre, axis=1) <= PATCH_RADIUS_M
        if on.any():
            d[on] += spurious.amount
            if "laser_spurious" not in faults.fired:
                faults.fire(
                    "laser_spurious",
                    f"a patch returns ranges {spurious.amount * 1e3:g} mm too long",
                )

    def cast(self, data: mujoco.MjData) -> np.ndarray:
        """(n_rays,) measured ranges [m] at the current state, NaN for no return."""
        c = self.config
        mujoco.mj_kinematics(self.model, data)  # poses of the current qpos (mj_step lags one)
        R = data.site_xmat[self.site].reshape(3, 3)
        vec = self.dirs_tcp @ R.T
        mujoco.mj_multiRay(
            self.model,
            data,
            data.site_xpos[self.site],
            vec.reshape(-1),
            RAY_GROUPS,
            1,
            -1,
            self._geomid,
            self._dist,
            self._normal,
            c.n_rays,
            c.range_max_m,
        )
        d = self._dist * (1.0 + self.scale)
        self._faulty(data, d, vec)
        cos_incidence = -np.einsum("ij,ij->i", self._normal.reshape(-1, 3), vec)
        ok = (self._geomid >= 0) & (d >= c.range_min_m) & (d <= c.range_max_m)
        ok &= cos_incidence >= self._cos_max
        if c.dropout > 0.0:
            ok &= self.rng.random(c.n_rays) >= c.dropout
        if c.sigma_m > 0.0:
            d += self.rng.normal(0.0, c.sigma_m, c.n_rays)
        d[~ok] = np.nan
        if self.witness is not None:
            self.witness(data, data.site_xpos[self.site].copy(), vec, d.copy())
        return d


class IRSensor:
    """One ray along the IR TCP's z axis; short range, Gaussian noise."""

    def __init__(
        self, model: mujoco.MjModel, site: int, config: IRConfig, rng: np.random.Generator
    ) -> None:
        self.model = model
        self.site = site
        self.config = config
        self.rng = rng
        self._geomid = np.zeros(1, dtype=np.int32)
        #: A witness of every reading, as the laser's (one ray; NaN = no return).
        self.witness: Callable[[mujoco.MjData, np.ndarray, np.ndarray, np.ndarray], None] | None
        self.witness = None

    def cast(self, data: mujoco.MjData) -> float | None:
        """Measured distance [m], or None when nothing is within range."""
        dist = self._cast(data)
        if self.witness is not None:
            site = self.site
            self.witness(
                data,
                data.site_xpos[site].copy(),
                data.site_xmat[site].reshape(3, 3)[:, 2][None, :].copy(),
                np.array([np.nan if dist is None else dist]),
            )
        return dist

    def _cast(self, data: mujoco.MjData) -> float | None:
        c = self.config
        mujoco.mj_kinematics(self.model, data)
        direction = data.site_xmat[self.site].reshape(3, 3)[:, 2].copy()
        dist = mujoco.mj_ray(
            self.model,
            data,
            data.site_xpos[self.site],
            direction,
            RAY_GROUPS,
            1,
            -1,
            self._geomid,
        )
        if self._geomid[0] < 0 or not c.range_min_m <= dist <= c.range_max_m:
            return None
        if c.sigma_m > 0.0:
            dist += float(self.rng.normal(0.0, c.sigma_m))
        return float(dist)


class LightBeam:
    """A light barrier between two fixed points (world frame [m]): broken when the arm or a
    tool stands in the beam (the TCP check station's sensor)."""

    GROUPS = np.array([0, 0, 0, 1, 1, 0], dtype=np.uint8)  # the arm's solids, the tools

    def __init__(self, model: mujoco.MjModel, p_from: np.ndarray, p_to: np.ndarray) -> None:
        self.model = model
        self.p_from = np.asarray(p_from, dtype=float)
        self.p_to = np.asarray(p_to, dtype=float)
        v = self.p_to - self.p_from
        self.length = float(np.linalg.norm(v))
        self.direction = v / self.length
        self._geomid = np.zeros(1, dtype=np.int32)

    def broken(self, data: mujoco.MjData) -> bool:
        mujoco.mj_kinematics(self.model, data)
        d = mujoco.mj_ray(
            self.model, data, self.p_from, self.direction, self.GROUPS, 1, -1, self._geomid
        )
        return bool(self._geomid[0] >= 0 and d <= self.length)
