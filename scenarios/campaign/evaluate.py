"""The evaluator of a registration trial: the only code of a campaign that reads the truth.

Errors are measured where they matter, at the operation targets: a target of the virtual
model (model frame) is placed in the table frame through the estimated pose and through the
true one; their distance is the target error. The predicted TRE is the matcher's own
estimate of that distance, so measured / predicted tells how well it is calibrated.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from registration import invert, rotation_angle, transform_points


@dataclass(frozen=True)
class TrialEvaluation:
    """Errors of one registration against the truth.

    Attributes:
        target_error: (K,) distance between each target placed by the estimated and by the
            true pose [m].
        target_error_real: (K,) distance between each target placed by the estimated pose
            and the real entity's target (model error included) [m].
        predicted_tre: (K,) the matcher's predicted TRE at each target [m].
        rotation_error: angle of the pose error [rad].
        centroid_error: displacement of the model's centroid by the pose error [m].
        accepted: the matcher's verdict was "accepted".
        right_object: the scanned object is the model matched against.
        false_accept: accepted although the object is wrong or a target error exceeds the
            threshold.
        good: right object and every target error within the threshold.
    """

    target_error: np.ndarray
    target_error_real: np.ndarray
    predicted_tre: np.ndarray
    rotation_error: float
    centroid_error: float
    accepted: bool
    right_object: bool
    false_accept: bool
    good: bool

    @property
    def tre_ratio(self) -> np.ndarray:
        """(K,) measured / predicted TRE (inf where nothing was predicted)."""
        with np.errstate(divide="ignore"):
            return np.where(self.predicted_tre > 0, self.target_error / self.predicted_tre, np.inf)


def evaluate_registration(
    T_model_table_estimate: np.ndarray,
    T_table_object_true: np.ndarray,
    targets_model: np.ndarray,
    targets_real: np.ndarray,
    centroid_model: np.ndarray,
    predicted_tre: np.ndarray,
    accepted: bool,
    right_object: bool,
    threshold: float,
) -> TrialEvaluation:
    """Compare an estimated pose (4, 4) (table -> model) with the truth (4, 4) (object ->
    table) at the targets (K, 3) of the virtual model, the real entity's targets (K, 3) and
    the centroid (3,) [m]; `threshold` [m] is the target error of a false accept."""
    T_table_model_estimate = invert(T_model_table_estimate)
    placed = transform_points(T_table_model_estimate, targets_model)
    target_error = np.linalg.norm(
        placed - transform_points(T_table_object_true, targets_model), axis=1
    )
    target_error_real = np.linalg.norm(
        placed - transform_points(T_table_object_true, targets_real), axis=1
    )
    dR = T_table_model_estimate[:3, :3] @ T_table_object_true[:3, :3].T
    c = np.asarray(centroid_model, dtype=float)[None]
    centroid_error = float(
        np.linalg.norm(
            transform_points(T_table_model_estimate, c) - transform_points(T_table_object_true, c)
        )
    )
    within = bool(np.all(target_error <= threshold))
    return TrialEvaluation(
        target_error=target_error,
        target_error_real=target_error_real,
        predicted_tre=np.asarray(predicted_tre, dtype=float),
        rotation_error=rotation_angle(dR),
        centroid_error=centroid_error,
        accepted=accepted,
        right_object=right_object,
        false_accept=accepted and not (right_object and within),
        good=right_object and within,
    )
