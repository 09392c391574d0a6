"""Surface matching on numpy arrays: robust multi-start ICP (points, meshes, surfaces).

The seed paper's algorithm, usable on its own: Horn's absolute orientation (weighted),
Haralick's robust estimator with Tukey weights, the closest-point operator on point sets,
segments, triangle meshes and parametric surfaces, ICP, initial states for global and local
matching, and the quality of the result (covariance, predicted TRE, ambiguity, verdict).

    >>> from registration import match, MeshModel
    >>> result = match(scan_points, MeshModel(vertices, faces), mode="local")
    >>> result.T_model_data, result.verdict, result.predicted_tre(targets)
"""

from registration.errors import FormatError, InputError, RegistrationError
from registration.haralick import RobustFit, haralick
from registration.horn import absolute_orientation, absolute_orientation_batch
from registration.icp import IcpResult, icp
from registration.kernels import L2, Kernel, Trimmed, Tukey, median_absolute_deviation
from registration.match import MODES, MatchResult, Minimum, SearchSettings, as_shape, match
from registration.quality import (
    Acceptance,
    ResidualCorrelation,
    ScanPasses,
    pose_covariance,
    predicted_tre,
    residual_correlation,
    trimmed_rms,
)
from registration.rigid import invert, make_T, pose_error, rotation_angle, transform_points
from registration.shapes import (
    Closest,
    MeshModel,
    ParametricModel,
    PointModel,
    SegmentModel,
    Shape,
)
from registration.starts import super_fibonacci_rotations

__all__ = [
    "L2",
    "MODES",
    "Acceptance",
    "Closest",
    "FormatError",
    "IcpResult",
    "InputError",
    "Kernel",
    "MatchResult",
    "MeshModel",
    "Minimum",
    "ParametricModel",
    "PointModel",
    "RegistrationError",
    "ResidualCorrelation",
    "RobustFit",
    "ScanPasses",
    "SearchSettings",
    "SegmentModel",
    "Shape",
    "Trimmed",
    "Tukey",
    "absolute_orientation",
    "absolute_orientation_batch",
    "as_shape",
    "haralick",
    "icp",
    "invert",
    "make_T",
    "match",
    "median_absolute_deviation",
    "pose_covariance",
    "pose_error",
    "predicted_tre",
    "residual_correlation",
    "rotation_angle",
    "super_fibonacci_rotations",
    "transform_points",
    "trimmed_rms",
]
