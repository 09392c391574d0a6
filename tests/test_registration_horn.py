"""Horn's absolute orientation: exact recovery, weights, brute-force optimum, properties."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize
from scipy.spatial.transform import Rotation

from registration import InputError
from registration.horn import absolute_orientation
from registration.rigid import make_T, transform_points


def _random_problem(seed: int, n: int = 20, noise: float = 0.0):
    rng = np.random.default_rng(seed)
    data = rng.normal(size=(n, 3))
    R = Rotation.random(random_state=rng).as_matrix()
    t = rng.normal(size=3)
    model = data @ R.T + t + rng.normal(scale=noise, size=(n, 3))
    return data, model, R, t


def test_exact_pairs_are_recovered_to_machine_precision() -> None:
    data, model, R, t = _random_problem(0)
    R_est, t_est = absolute_orientation(data, model)
    np.testing.assert_allclose(R_est, R, atol=1e-12)
    np.testing.assert_allclose(t_est, t, atol=1e-12)


def _weighted_cost(x: np.ndarray, data, model, w) -> float:
    R = Rotation.from_rotvec(x[3:]).as_matrix()
    return float(np.sum(w * np.sum((model - data @ R.T - x[:3]) ** 2, axis=1)))


@pytest.mark.parametrize("seed", range(5))
def test_weighted_solution_matches_brute_force_optimum(seed: int) -> None:
    data, model, _, _ = _random_problem(seed, n=15, noise=0.3)
    w = np.random.default_rng(100 + seed).uniform(0.0, 1.0, size=len(data))
    R, t = absolute_orientation(data, model, w)
    horn = _weighted_cost(np.concatenate([t, Rotation.from_matrix(R).as_rotvec()]), data, model, w)
    # Independent optimum: Nelder-Mead / BFGS from many starts on the 6-D pose.
    best = np.inf
    rng = np.random.default_rng(seed)
    for _ in range(20):
        x0 = np.concatenate([rng.normal(size=3), Rotation.random(random_state=rng).as_rotvec()])
        res = minimize(_weighted_cost, x0, args=(data, model, w), method="BFGS")
        best = min(best, res.fun)
    assert horn <= best + 1e-9  # Horn is at least as good as the brute-force search
    assert horn == pytest.approx(best, rel=1e-6)


def test_weights_enter_the_cross_covariance_not_only_the_centroids() -> None:
    data, model, R, t = _random_problem(1, n=30)
    corrupted = model.copy()
    corrupted[:10] = corrupted[:10] @ Rotation.from_rotvec([0, 0, 1.0]).as_matrix().T
    w = np.r_[np.zeros(10), np.ones(20)]
    R_est, t_est = absolute_orientation(data, corrupted, w)
    np.testing.assert_allclose(R_est, R, atol=1e-10)
    np.testing.assert_allclose(t_est, t, atol=1e-10)


def test_mirrored_data_still_give_a_proper_rotation() -> None:
    data, _, _, _ = _random_problem(2)
    mirrored = data * np.array([-1.0, 1.0, 1.0])
    R, _ = absolute_orientation(data, mirrored)
    assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-12)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), noise=st.floats(0.0, 0.5))
def test_det_is_plus_one_and_order_does_not_matter(seed: int, noise: float) -> None:
    data, model, _, _ = _random_problem(seed, n=12, noise=noise)
    w = np.random.default_rng(seed).uniform(0.1, 1.0, size=12)
    R, t = absolute_orientation(data, model, w)
    assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-9)
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-9)
    perm = np.random.default_rng(seed + 1).permutation(12)
    R_p, t_p = absolute_orientation(data[perm], model[perm], w[perm])
    np.testing.assert_allclose(R_p, R, atol=1e-9)
    np.testing.assert_allclose(t_p, t, atol=1e-9)
    moved = transform_points(make_T(R, t), data)
    assert np.all(np.isfinite(moved))


def test_bad_input_is_named() -> None:
    with pytest.raises(InputError, match=r"\(N, 3\)"):
        absolute_orientation(np.zeros((5, 2)), np.zeros((5, 2)))
    with pytest.raises(InputError, match="weights"):
        absolute_orientation(np.eye(3), np.eye(3), np.array([-1.0, 1.0, 1.0]))
