"""Model error: how the real entity differs from its virtual model (CT segmentation, CAD
tolerance). The real surface is the virtual one displaced by a smooth low-frequency deformation
plus correlated surface noise along the normals; both are seeded and of configured RMS.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import trimesh

from models.mesh import TriangleMesh
from models.model_errors import ModelParameterError

_MODES = 8  # Fourier modes of the smooth deformation


@dataclass(frozen=True)
class ModelErrorSpec:
    """Magnitudes of the model error [m].

    `deformation_rms`: RMS over the vertices of the smooth displacement vectors, a field of
    wavelength about `wavelength` (sum of random plane waves). `noise_rms`: RMS of the surface
    noise along the vertex normals, correlated over about `noise_correlation`. The defaults give
    0.30 mm RMS displacement in total (0.24 and 0.18 mm), a CT-derived model's error.
    The error lives on the mesh vertices: a mesh with long edges gets a coarser error (the
    built-in models have edges of 3 mm at most).
    """

    deformation_rms: float = 0.24e-3
    noise_rms: float = 0.18e-3
    wavelength: float = 0.08
    noise_correlation: float = 2e-3

    def __post_init__(self) -> None:
        for name in ("deformation_rms", "noise_rms"):
            value = getattr(self, name)
            if not 0.0 <= value <= 5e-3:
                raise ModelParameterError(f"{name} must lie in [0, 5e-3] m, got {value}")
        if not 1e-3 <= self.wavelength <= 10.0:
            raise ModelParameterError(f"wavelength must lie in [1e-3, 10] m, got {self.wavelength}")
        if not 0.0 <= self.noise_correlation <= 0.05:
            raise ModelParameterError(
                f"noise_correlation must lie in [0, 0.05] m, got {self.noise_correlation}"
            )

    @property
    def total_rms(self) -> float:
        """Expected RMS of the whole vertex displacement [m] (the two parts are independent)."""
        return float(np.hypot(self.deformation_rms, self.noise_rms))


@dataclass(frozen=True, eq=False)
class Deformation:
    """The smooth part of a model error: displacement(p) = sum_k a_k sin(w_k . p + phi_k).

    `wavenumbers` (K, 3) [rad/m], `phases` (K,), `amplitudes` (K, 3) [m].
    """

    wavenumbers: np.ndarray
    phases: np.ndarray
    amplitudes: np.ndarray

    def __call__(self, p: np.ndarray) -> np.ndarray:
        """Displacement (N, 3) [m] at points `p` (N, 3) [m]."""
        return np.sin(np.asarray(p) @ self.wavenumbers.T + self.phases) @ self.amplitudes


@dataclass(frozen=True, eq=False)
class ModelErrorResult:
    """The real surface and the parts of its displacement from the virtual one, per vertex.

    `mesh` is the real surface, with the faces of the virtual one [m]; `deformation` (N, 3)
    and `noise` (N,)
    (along `normals` (N, 3)) [m]; `field` evaluates the smooth part anywhere (for the contact
    pieces).
    """

    mesh: TriangleMesh
    deformation: np.ndarray
    noise: np.ndarray
    normals: np.ndarray
    field: Deformation

    @property
    def displacement(self) -> np.ndarray:
        """Whole vertex displacement real - virtual, (N, 3) [m]."""
        return self.deformation + self.noise[:, None] * self.normals


def _smoothed_noise(
    mesh: trimesh.Trimesh, correlation: float, rng: np.random.Generator
) -> np.ndarray:
    """White noise on the vertices, averaged over neighbours until it is correlated over about
    `correlation` [m] (each averaging step spreads it by about one edge length)."""
    noise = rng.standard_normal(len(mesh.vertices))
    if correlation <= 0:
        return noise
    edge = float(mesh.edges_unique_length.mean())
    steps = int(np.ceil((correlation / edge) ** 2))
    edges = mesh.edges_unique
    n = len(mesh.vertices)
    adjacency = sp.coo_matrix(
        (
            np.ones(2 * len(edges)),
            (np.r_[edges[:, 0], edges[:, 1]], np.r_[edges[:, 1], edges[:, 0]]),
        ),
        shape=(n, n),
    ).tocsr()
    adjacency = adjacency + sp.identity(n, format="csr")
    average = sp.diags(1.0 / np.asarray(adjacency.sum(axis=1)).ravel()) @ adjacency
    for _ in range(steps):
        noise = average @ noise
    return noise


def apply_model_error(
    mesh: TriangleMesh, spec: ModelErrorSpec | None = None, seed: int = 0
) -> ModelErrorResult:
    """The real surface: `mesh` [m] displaced by the model error `spec`, deterministic in `seed`.

    The deformation and the noise are each scaled to their configured RMS over the vertices
    exactly; the noise has zero mean (it does not shift the surface as a whole).
    """
    spec = spec or ModelErrorSpec()
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ModelParameterError(f"seed must be a non-negative integer, got {seed!r}")
    rng = np.random.default_rng([int(seed), 0x4D45])  # own stream, apart from shape seeds
    tm = mesh.to_trimesh()
    vertices = np.asarray(mesh.vertices)

    directions = rng.standard_normal((_MODES, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    wavelengths = spec.wavelength * rng.uniform(0.7, 1.4, size=_MODES)
    field = Deformation(
        wavenumbers=2 * np.pi * directions / wavelengths[:, None],
        phases=rng.uniform(0, 2 * np.pi, size=_MODES),
        amplitudes=rng.standard_normal((_MODES, 3)),
    )
    deformation = field(vertices)
    rms = float(np.sqrt(np.mean(np.sum(deformation**2, axis=1))))
    scale = spec.deformation_rms / rms if rms > 0 else 0.0
    field = Deformation(field.wavenumbers, field.phases, field.amplitudes * scale)
    deformation = deformation * scale

    noise = _smoothed_noise(tm, spec.noise_correlation, rng)
    noise -= noise.mean()
    noise_rms = float(np.sqrt(np.mean(noise**2)))
    noise = noise * (spec.noise_rms / noise_rms if noise_rms > 0 else 0.0)
    normals = np.asarray(tm.vertex_normals)

    real = TriangleMesh(vertices + deformation + noise[:, None] * normals, mesh.faces)
    return ModelErrorResult(real, deformation, noise, normals, field)
