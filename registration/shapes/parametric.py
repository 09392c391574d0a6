"""A model given as a parametric surface r(u, v) (eq. 17-18).

As in the seed paper, the surface is first approximated by triangles whose vertices lie on
it; the closest triangle point gives a parameter guess (u, v), which is then refined on the
surface itself by damped Gauss-Newton (Levenberg-Marquardt) on |r(u, v) - p|^2.
"""

from __future__ import annotations

from collections.abc import Callable

import igl
import numpy as np

from registration.registration_errors import InputError
from registration.rigid import Array
from registration.shapes.base import Closest, Shape, check_points

SurfaceFunction = Callable[[Array, Array], Array]


class ParametricModel(Shape):
    """Model as a parametric surface.

    Args:
        r: vectorised function r(u, v) -> points (..., 3) for parameter arrays u, v (...).
        u_range, v_range: the parameter domain [lo, hi] of u and v.
        periodic_u, periodic_v: True if the surface closes on itself along that parameter.
        resolution: triangulation grid (nu, nv); finer grids give better initial guesses.
        refine_iterations: Newton steps on the surface itself (0: triangles only).
    """

    has_normals = True
    oriented = True

    def __init__(
        self,
        r: SurfaceFunction,
        u_range: tuple[float, float],
        v_range: tuple[float, float],
        periodic_u: bool = False,
        periodic_v: bool = False,
        resolution: tuple[int, int] = (96, 48),
        refine_iterations: int = 10,
    ) -> None:
        if not callable(r):
            raise InputError(f"r must be a callable r(u, v) -> (..., 3); got {type(r).__name__}")
        for name, rng in (("u_range", u_range), ("v_range", v_range)):
            if len(rng) != 2 or not np.isfinite(rng).all() or not rng[1] > rng[0]:
                raise InputError(f"{name} must be [lo, hi] with lo < hi; got {rng}")
        nu, nv = resolution
        if nu < 2 or nv < 2:
            raise InputError(f"resolution must be at least (2, 2); got {resolution}")
        self.r = r
        self.u_range = (float(u_range[0]), float(u_range[1]))
        self.v_range = (float(v_range[0]), float(v_range[1]))
        self.periodic = (periodic_u, periodic_v)
        self.refine_iterations = refine_iterations
        u, v = np.meshgrid(
            np.linspace(*self.u_range, nu + 1), np.linspace(*self.v_range, nv + 1), indexing="ij"
        )
        self._uv = np.stack([u.ravel(), v.ravel()], axis=1)
        self.vertices = check_points(
            np.asarray(r(u.ravel(), v.ravel()), dtype=float), "surface points r(u, v)", 3
        )
        idx = np.arange((nu + 1) * (nv + 1)).reshape(nu + 1, nv + 1)
        a, b, c, d = idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]
        faces = np.concatenate(
            [np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)]
        )
        # Drop the triangles a pole or a seam collapses (zero area): no parameters inside.
        tri = self.vertices[faces]
        area2 = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
        self.faces = np.ascontiguousarray(faces[area2 > 1e-12 * area2.max()], dtype=np.int64)
        self._tree = igl.AABB()
        self._tree.init(self.vertices, self.faces)
        su, sv = np.meshgrid(
            np.linspace(*self.u_range, 4 * nu, endpoint=not periodic_u),
            np.linspace(*self.v_range, 4 * nv),
            indexing="ij",
        )
        self.samples = np.asarray(r(su.ravel(), sv.ravel()), dtype=float)
        self.sample_normals = self._normals(su.ravel(), sv.ravel())

    def _partials(self, u: Array, v: Array) -> tuple[Array, Array]:
        hu = 1e-6 * (self.u_range[1] - self.u_range[0])
        hv = 1e-6 * (self.v_range[1] - self.v_range[0])
        ru = (self.r(u + hu, v) - self.r(u - hu, v)) / (2 * hu)
        rv = (self.r(u, v + hv) - self.r(u, v - hv)) / (2 * hv)
        return np.asarray(ru, dtype=float), np.asarray(rv, dtype=float)

    def _second_partials(self, u: Array, v: Array) -> tuple[Array, Array, Array]:
        hu = 1e-4 * (self.u_range[1] - self.u_range[0])
        hv = 1e-4 * (self.v_range[1] - self.v_range[0])
        r0 = np.asarray(self.r(u, v), dtype=float)
        ruu = (self.r(u + hu, v) - 2 * r0 + self.r(u - hu, v)) / hu**2
        rvv = (self.r(u, v + hv) - 2 * r0 + self.r(u, v - hv)) / hv**2
        ruv = (
            self.r(u + hu, v + hv)
            - self.r(u + hu, v - hv)
            - self.r(u - hu, v + hv)
            + self.r(u - hu, v - hv)
        ) / (4 * hu * hv)
        return np.asarray(ruu, float), np.asarray(ruv, float), np.asarray(rvv, float)

    def _normals(self, u: Array, v: Array) -> Array:
        ru, rv = self._partials(u, v)
        n = np.cross(ru, rv)
        norm = np.linalg.norm(n, axis=-1, keepdims=True)
        return n / np.where(norm > 0, norm, 1.0)

    def _clamp(self, u: Array, v: Array) -> tuple[Array, Array]:
        out = []
        for x, (lo, hi), periodic in zip(
            (u, v), (self.u_range, self.v_range), self.periodic, strict=True
        ):
            out.append(lo + np.mod(x - lo, hi - lo) if periodic else np.clip(x, lo, hi))
        return out[0], out[1]

    def closest(self, points: Array) -> Closest:
        p = np.ascontiguousarray(points, dtype=float)
        _, face, c = self._tree.squared_distance(self.vertices, self.faces, p)
        # Parameters of the closest triangle point by barycentric interpolation.
        tri = self.vertices[self.faces[face]]
        bary = igl.barycentric_coordinates(
            np.ascontiguousarray(c),
            np.ascontiguousarray(tri[:, 0]),
            np.ascontiguousarray(tri[:, 1]),
            np.ascontiguousarray(tri[:, 2]),
        )
        uv = np.einsum("nk,nkd->nd", bary, self._uv[self.faces[face]])
        u, v = uv[:, 0], uv[:, 1]
        best = np.asarray(self.r(u, v), dtype=float)
        err = np.sum((best - p) ** 2, axis=1)
        lam = np.full(len(p), 1e-3)
        for _ in range(self.refine_iterations):
            # Newton on f(u, v) = |r - p|^2 / 2 with the curvature term (Gauss-Newton alone
            # converges only linearly, at a rate ~ distance x curvature), damped
            # Levenberg-Marquardt style; a step is taken only if it brings r closer to p.
            ru, rv = self._partials(u, v)
            ruu, ruv, rvv = self._second_partials(u, v)
            res = best - p
            g = np.stack([np.einsum("nd,nd->n", ru, res), np.einsum("nd,nd->n", rv, res)], 1)
            H = np.empty((len(p), 2, 2))
            H[:, 0, 0] = np.einsum("nd,nd->n", ru, ru) + np.einsum("nd,nd->n", ruu, res)
            H[:, 1, 1] = np.einsum("nd,nd->n", rv, rv) + np.einsum("nd,nd->n", rvv, res)
            H[:, 0, 1] = H[:, 1, 0] = np.einsum("nd,nd->n", ru, rv) + np.einsum(
                "nd,nd->n", ruv, res
            )
            gn = np.einsum("nd,nd->n", ru, ru) + np.einsum("nd,nd->n", rv, rv)
            damp = (lam * np.maximum(gn, 1e-300))[:, None, None] * np.eye(2)
            step = -np.linalg.solve(H + damp, g[..., None])[..., 0]
            un, vn = self._clamp(u + step[:, 0], v + step[:, 1])
            cand = np.asarray(self.r(un, vn), dtype=float)
            cerr = np.sum((cand - p) ** 2, axis=1)
            better = cerr < err
            u, v = np.where(better, un, u), np.where(better, vn, v)
            best = np.where(better[:, None], cand, best)
            err = np.where(better, cerr, err)
            lam = np.where(better, lam * 0.1, lam * 10.0)
        # The refined point is never farther than the triangle point's surface image.
        return Closest(best, self._normals(u, v), np.sqrt(err))
