"""Exceptions of the models package.

Every error a user can cause (a bad file, a bad name, a bad parameter) is a `ModelError`; the
subclasses also inherit the matching built-in exception so that callers may catch either.
"""

from __future__ import annotations


class ModelError(Exception):
    """Root of every error raised by `models`."""


class UnknownModelError(ModelError, LookupError):
    """A model name that is neither a built-in model nor a mesh file."""

    def __str__(self) -> str:  # LookupError would quote the message like a dict key
        return str(self.args[0]) if self.args else ""


class MeshFileError(ModelError, ValueError):
    """A mesh file that is missing, empty, corrupt, not a mesh, or in an unsupported format."""


class MeshDataError(ModelError, ValueError):
    """Mesh arrays that are unusable: wrong shapes, NaN/inf vertices, bad indices, no area."""


class ModelParameterError(ModelError, ValueError):
    """A parameter outside its valid range (seed, units, error magnitudes, resolution...)."""
