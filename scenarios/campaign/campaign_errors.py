"""Errors of campaigns: bad campaign options, sweeps and folders."""

from __future__ import annotations

from scenarios.scenario_errors import ScenarioError


class CampaignError(ScenarioError, ValueError):
    """A campaign option, sweep, configuration or folder is invalid."""
