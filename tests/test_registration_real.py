"""Auto mode on real range scans (the Stanford dragon and Happy Buddha, tests/data/stanford):
single scanner views covering 14-34 % of the object, matched to the reconstructed mesh
without a prior, from 200 random orientations; ground truth from the scanning repository's
own alignment (the views fit the model to 0.1 mm median under it)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from registration import make_T, match, transform_points

#: A pose is right if it puts the scan within 1 mm RMS of where the true pose puts it (the
#: truth itself fits to about 0.1 mm).
RIGHT_M = 1e-3


def _displacement(T_a: np.ndarray, T_b: np.ndarray, points: np.ndarray) -> float:
    d = transform_points(T_a, points) - transform_points(T_b, points)
    return float(np.sqrt(np.mean(np.sum(d**2, axis=1))))


def _random_pose(rng: np.random.Generator) -> np.ndarray:
    return make_T(Rotation.random(random_state=rng).as_matrix(), rng.normal(scale=0.3, size=3))


@pytest.mark.slow
def test_auto_mode_finds_every_real_view_from_200_orientations(real_objects) -> None:
    rng = np.random.default_rng(2026)
    views = [(obj, scan) for obj in real_objects for scan in obj.scans]
    models = {obj.name: obj.model() for obj in real_objects}
    wrong, accepted = [], 0
    for k in range(200):
        obj, scan = views[k % len(views)]
        T_data_scan = _random_pose(rng)
        data = transform_points(T_data_scan, scan.points)
        T_truth = scan.T_model_scan @ np.linalg.inv(T_data_scan)
        r = match(data, models[obj.name])
        error = _displacement(r.T_model_data, T_truth, data[::50])
        if error > RIGHT_M:
            wrong.append((k, scan.name, r.verdict, round(error * 1e3, 1)))
        accepted += r.verdict == "accepted"
    assert wrong == []
    # Single views of these statues have no symmetry and fit to 0.1 mm: all are accepted.
    assert accepted == 200


def test_real_views_with_40_percent_spurious_points(real_objects) -> None:
    rng = np.random.default_rng(7)
    for obj in real_objects:
        model = obj.model()
        for scan in obj.scans[::2]:
            lo, hi = scan.points.min(axis=0), scan.points.max(axis=0)
            pad = 0.2 * (hi - lo)
            n_out = int(0.4 / 0.6 * len(scan.points))
            spurious = rng.uniform(lo - pad, hi + pad, size=(n_out, 3))
            points = np.vstack([scan.points, spurious])[rng.permutation(len(scan.points) + n_out)]
            T_data_scan = _random_pose(rng)
            data = transform_points(T_data_scan, points)
            r = match(data, model)
            T_truth = scan.T_model_scan @ np.linalg.inv(T_data_scan)
            assert _displacement(r.T_model_data, T_truth, data[::50]) < RIGHT_M, scan.name
            assert r.verdict == "accepted", (scan.name, r.reason)
            assert 0.5 < r.inlier_fraction < 0.7  # the spurious 40 % found as outliers
