"""Model shapes and their closest-point operators (the C operator of the seed paper)."""

from registration.shapes.base import Closest, Shape, estimate_normals
from registration.shapes.mesh_shape import MeshModel, sample_surface
from registration.shapes.parametric import ParametricModel
from registration.shapes.points import PointModel
from registration.shapes.segments import SegmentModel

__all__ = [
    "Closest",
    "MeshModel",
    "ParametricModel",
    "PointModel",
    "SegmentModel",
    "Shape",
    "estimate_normals",
    "sample_surface",
]
