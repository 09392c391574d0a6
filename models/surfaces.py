"""Analytic surfaces r(u, v) that registration can match against (plain numpy functions)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from models import ellipsoid
from models.model_errors import ModelParameterError

SurfaceFunction = Callable[[np.ndarray, np.ndarray], np.ndarray]


@dataclass(frozen=True, eq=False)
class AnalyticSurface:
    """A parametric surface: `r(u, v)` -> points (..., 3) [m] for parameter arrays (...),
    over the domain `u_range` x `v_range`; `periodic_u`/`periodic_v` if it closes on itself."""

    name: str
    r: SurfaceFunction
    u_range: tuple[float, float]
    v_range: tuple[float, float]
    periodic_u: bool = False
    periodic_v: bool = False

    def __post_init__(self) -> None:
        for label, (lo, hi) in (("u_range", self.u_range), ("v_range", self.v_range)):
            if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
                raise ModelParameterError(f"{label} must be [lo, hi] with lo < hi, got {lo, hi}")

    def __call__(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self.r(u, v)


def ellipsoid_radii() -> tuple[float, float, float]:
    """Semi-axes of the paper's ellipsoid in the cell [m] (100, 60 and 40 mm)."""
    a, b, c = ellipsoid.RADII
    return (float(a), float(b), float(c))


def ellipsoid_surface() -> AnalyticSurface:
    """The paper's ellipsoid as r(u, v) [m]: u longitude in [0, 2 pi), v colatitude [0, pi]."""
    radii = ellipsoid_radii()

    def r(u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return ellipsoid.surface_point(u, v, radii)

    return AnalyticSurface("ellipsoid", r, ellipsoid.U_RANGE, ellipsoid.V_RANGE, periodic_u=True)
