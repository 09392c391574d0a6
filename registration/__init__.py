"""Surface matching on numpy arrays: robust multi-start ICP (points, meshes, surfaces).

The seed paper's algorithm, usable on its own: Horn's absolute orientation (weighted),
Haralick's robust estimator with Tukey weights, the closest-point operator on point sets,
segments, triangle meshes and parametric surfaces, ICP, initial states for global and local
matching, the model's own symmetries, and the quality of the result (covariance, predicted
TRE, ambiguity, verdict per target).

    >>> from registration import MeshModel, match
    >>> result = match(scan_points, MeshModel(vertices, faces))          # mode="auto"
    >>> result.T_model_data, result.verdict, result.predicted_tre(targets).verdict

One call, one result: `match` returns a `MatchResult`; `prepare(model)` builds once what many
matches against one model share, and `save_prepared` / `load_prepared` (registration.prepared)
keep it in a .twm file for other processes. The building blocks and the search's internals stay in
their modules (registration.icp, registration.horn, registration.haralick,
registration.search with its `SearchSettings`, registration.result's `Minimum` and
`SearchTrace`, registration.quality's `ScanPasses`, registration.symmetry, ...) for those who
want them.
"""

from registration.io import load_model, load_points
from registration.kernels import L2, Kernel, Trimmed, Tukey
from registration.match_request import MODES
from registration.matcher import match
from registration.prepare import prepare
from registration.prepared import load_prepared, save_prepared
from registration.registration_errors import FormatError, InputError, RegistrationError
from registration.result import MatchResult
from registration.rigid import invert, make_T, pose_error, rotation_angle, transform_points
from registration.shapes import (
    MeshModel,
    ParametricModel,
    PointModel,
    SegmentModel,
    Shape,
)
from registration.symmetry import Symmetry
from registration.verdict import Acceptance, TargetPrediction

__all__ = [
    "L2",
    "MODES",
    "Acceptance",
    "FormatError",
    "InputError",
    "Kernel",
    "MatchResult",
    "MeshModel",
    "ParametricModel",
    "PointModel",
    "RegistrationError",
    "SegmentModel",
    "Shape",
    "Symmetry",
    "TargetPrediction",
    "Trimmed",
    "Tukey",
    "invert",
    "load_model",
    "load_points",
    "load_prepared",
    "make_T",
    "match",
    "pose_error",
    "prepare",
    "rotation_angle",
    "save_prepared",
    "transform_points",
]
