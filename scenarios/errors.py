"""Exceptions of the scenarios package."""

from __future__ import annotations


class ScenarioError(Exception):
    """Root of every error raised by `scenarios`."""
