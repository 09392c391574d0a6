"""What the offline stages share about moving the arm in the cell: the table positions tried
for reach, the error when none serves, and the safe tool change."""

from __future__ import annotations

from cell import Controller
from scenarios.errors import ScenarioError

#: Table positions tried, in order, for a pass or an operation the arm must reach [m].
TABLE_CANDIDATES_M = (0.0, -0.1, 0.1, -0.2, 0.2, -0.3, 0.3, -0.4, 0.4)


class UnreachablePlanError(ScenarioError, ValueError):
    """No table position lets the arm reach a planned pass or operation."""


def change_tool_safely(controller: Controller, tool: str) -> None:
    """Change to `tool` through the home pose (wrist up, above the arm's base), before and
    after: the cell's tool change goes straight from where the arm is to the rack and back,
    and a joint move between the rack and the table can sweep the tool in hand through the
    tools hanging beside it in the rack."""
    if controller.tool_in_hand == tool:
        return
    controller.move_joints(controller.q_home)
    controller.change_tool(tool)
    controller.move_joints(controller.q_home)
