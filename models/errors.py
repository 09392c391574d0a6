"""Exceptions of the models package."""

from __future__ import annotations


class ModelError(Exception):
    """Root of every error raised by `models`."""
