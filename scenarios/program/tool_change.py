"""The safe tool change: through the home pose before and after, the one motion both the
planning's stages and the RAPID executor make on a controller."""

from __future__ import annotations

from cell import Controller


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
