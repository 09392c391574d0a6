"""Exceptions of the cell package."""

from __future__ import annotations


class CellError(Exception):
    """Root of every error raised by `cell`."""
