"""The error of a configuration file or value that cannot be used."""

from __future__ import annotations

from scenarios.scenario_errors import ScenarioError


class ConfigError(ScenarioError, ValueError):
    """A configuration file or value is invalid."""
