"""A model made ready for many matches: what `match` would build on its first call with a
model, built once, so that every call pays only for its data."""

from __future__ import annotations

from typing import TypeVar

from registration.search import SearchSettings
from registration.shapes.base import Shape
from registration.symmetry import find_symmetries

S = TypeVar("S", bound=Shape)


def prepare(shape: S) -> S:
    """Build now the trees, the voxel lookup, the anchors and the symmetries (at the default
    floor) of `shape` that `match` builds on its first call with it; returns the shape.

        >>> model = prepare(MeshModel(vertices, faces))  # once, for many scans of one model
    """
    settings = SearchSettings()
    _ = shape.sample_tree, shape.sample_lookup, shape.resolution
    shape.anchor_frames(settings.anchors, settings.normal_radius * shape.extent)
    shape.closest(shape.samples[:1])  # the exact operator's tree, where it has one
    find_symmetries(shape, 1e-4 * shape.extent)
    return shape
