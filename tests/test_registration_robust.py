"""Tukey weights (eq. 8) and Haralick's robust estimator with outliers."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from registration import L2, InputError, Trimmed, Tukey
from registration.haralick import haralick
from registration.kernels import median_absolute_deviation
from registration.rigid import make_T, pose_error


def test_tukey_weights_follow_equation_8() -> None:
    e = np.array([0.0, 1.0, -2.0, 3.0, 10.0, 100.0])
    # S = median |e - median(e)|: median(e) = 2.0 -> |e - 2| = 2,1,4,1,8,98 -> S = 3.0
    assert median_absolute_deviation(e) == pytest.approx(3.0)
    c = 6.0
    cs = c * 3.0
    expected = np.where(np.abs(e) <= cs, (1 - e**2 / cs**2) ** 2, 0.0)
    np.testing.assert_allclose(Tukey(c=c).weights(e), expected, rtol=0, atol=1e-15)
    assert Tukey(c=c).weights(e)[-1] == 0.0  # 100 > 18: rejected
    assert Tukey(c=c).weights(e)[0] == 1.0


def test_tukey_c_outside_the_paper_range_is_refused() -> None:
    for c in (5.9, 12.5):
        with pytest.raises(InputError, match=r"\[6, 12\]"):
            Tukey(c=c)


def test_scale_floor_keeps_noise_free_residuals() -> None:
    e = np.zeros(10)
    e[0] = 1e-9
    assert np.all(Tukey(min_scale=1e-6).weights(e) > 0.99)


def test_trimmed_keeps_the_smallest_fraction() -> None:
    e = np.arange(10.0)
    np.testing.assert_array_equal(Trimmed(keep=0.7).weights(e), (e <= 6).astype(float))


def _problem(seed: int, outliers: float):
    rng = np.random.default_rng(seed)
    data = rng.uniform(-0.1, 0.1, size=(200, 3))
    T = make_T(Rotation.random(random_state=rng).as_matrix(), rng.normal(scale=0.1, size=3))
    model = data @ T[:3, :3].T + T[:3, 3] + rng.normal(scale=1e-4, size=data.shape)
    bad = rng.choice(200, size=int(outliers * 200), replace=False)
    model[bad] += rng.uniform(-0.05, 0.05, size=(len(bad), 3))
    return data, model, T, bad


@pytest.mark.parametrize("seed", range(3))
def test_haralick_ignores_30_percent_gross_outliers(seed: int) -> None:
    data, model, T, bad = _problem(seed, 0.3)
    fit = haralick(data, model)
    rot, trans = pose_error(fit.T_model_data, T)
    assert np.degrees(rot) < 0.05  # noise 0.1 mm over 0.2 m: ~0.01 deg expected
    assert trans < 1e-4
    assert fit.converged
    # The outliers end with (almost) no weight, the inliers with nearly full weight.
    assert np.median(fit.weights[bad]) < 0.05
    good = np.setdiff1d(np.arange(200), bad)
    assert np.median(fit.weights[good]) > 0.8
    # Plain least squares is pulled by the same outliers: the robust estimator matters.
    plain = haralick(data, model, kernel=L2())
    assert pose_error(plain.T_model_data, T)[1] > 10 * trans
