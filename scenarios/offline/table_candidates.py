"""The table positions the planning tries, in order, for a pass or an operation the arm must
reach, and the error when none serves."""

from __future__ import annotations

from scenarios.scenario_errors import ScenarioError

#: Table positions tried, in order, for a pass or an operation the arm must reach [m].
TABLE_CANDIDATES_M = (0.0, -0.1, 0.1, -0.2, 0.2, -0.3, 0.3, -0.4, 0.4)


class UnreachablePlanError(ScenarioError, ValueError):
    """No table position lets the arm reach a planned pass or operation."""
