"""Robust kernels: objects that turn residuals into weights for the least-squares steps.

Tukey's biweight with a median-absolute-deviation scale is the seed paper's choice (eq. 8,
after Haralick). A kernel is passed in as an object, so a caller can supply their own.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from registration.registration_errors import InputError
from registration.rigid import Array


class Kernel(Protocol):
    """Maps residuals (..., N) to weights (..., N) in [0, 1], row by row."""

    def weights(self, residuals: Array) -> Array: ...


def median_absolute_deviation(residuals: Array, mask: Array | None = None) -> Array:
    """S of eq. 8: median of |e - median(e)| along the last axis; shape (...,).

    With a mask (same shape, True where a residual counts), each row's median is over its
    counted residuals alone (the lower median for an even count; inf for none)."""
    if mask is None:
        med = np.median(residuals, axis=-1, keepdims=True)
        return np.median(np.abs(residuals - med), axis=-1)
    count = mask.sum(axis=-1, keepdims=True)
    middle = np.maximum(count - 1, 0) // 2
    e = np.sort(np.where(mask, residuals, np.inf), axis=-1)
    med = np.take_along_axis(e, middle, axis=-1)
    dev = np.sort(np.where(mask, np.abs(residuals - med), np.inf), axis=-1)
    return np.where(count > 0, np.take_along_axis(dev, middle, axis=-1), np.inf)[..., 0]


@dataclass(frozen=True)
class L2:
    """Plain least squares: every point has weight 1."""

    def weights(self, residuals: Array) -> Array:
        return np.ones_like(residuals, dtype=float)


@dataclass(frozen=True)
class Tukey:
    """Tukey's biweight (eq. 8): w = (1 - e^2 / (c S)^2)^2 for |e| <= c S, else 0.

    Attributes:
        c: tuning constant; the paper takes it in [6, 12].
        min_scale: floor of S [length units], so that noise-free data (S = 0) keep their
            weights; set it near the sensor's resolution.
    """

    c: float = 8.0
    min_scale: float = 0.0

    def __post_init__(self) -> None:
        if not 6.0 <= self.c <= 12.0:
            raise InputError(f"Tukey's c must lie in [6, 12] (seed paper, eq. 8); got {self.c}")
        if self.min_scale < 0:
            raise InputError(f"Tukey's min_scale must be >= 0; got {self.min_scale}")

    def scale(self, residuals: Array, mask: Array | None = None) -> Array:
        """S of eq. 8 with its floor, shape (...,); with a mask, of the residuals it marks."""
        return np.maximum(median_absolute_deviation(residuals, mask), self.min_scale)

    def weights(self, residuals: Array) -> Array:
        return self.weights_at(residuals, self.scale(residuals))

    def weights_at(self, residuals: Array, scale: Array) -> Array:
        """Weights (..., N) with a given S (...,) instead of the residuals' own."""
        cs = self.c * np.maximum(scale, self.min_scale)[..., None]
        e = np.abs(residuals)
        with np.errstate(divide="ignore", invalid="ignore"):
            u = np.where(cs > 0, e / cs, np.where(e > 0, np.inf, 0.0))
        return np.where(u <= 1.0, (1.0 - u**2) ** 2, 0.0)


@dataclass(frozen=True)
class Trimmed:
    """Trimmed least squares: the `keep` fraction of smallest |residuals| gets weight 1."""

    keep: float = 0.7

    def __post_init__(self) -> None:
        if not 0.0 < self.keep <= 1.0:
            raise InputError(f"Trimmed keep fraction must lie in (0, 1]; got {self.keep}")

    def weights(self, residuals: Array) -> Array:
        e = np.abs(residuals)
        n = e.shape[-1]
        k = max(3, int(np.ceil(self.keep * n)))
        if k >= n:
            return np.ones_like(e, dtype=float)
        cut = np.partition(e, k - 1, axis=-1)[..., k - 1 : k]
        return (e <= cut).astype(float)
