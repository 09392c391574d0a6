"""A pick with the gripper: take the part at its grasp, lift it, hold it, put it down where
it was taken and open. The part is a loose body on the table; the gripper goes back to the
pick pose to put it down, so the program needs no new pose estimate of it."""

from __future__ import annotations

from cell import Controller
from scenarios.offline.hooks import StageHooks
from scenarios.offline.program_plan import execute_program
from scenarios.offline.settings import Pick
from scenarios.program.program_types import OfflineProgram
from scenarios.program.tool_change import change_tool_safely


def execute_pick(
    controller: Controller, grasp: OfflineProgram, pick: Pick, hooks: StageHooks
) -> None:
    """Run the one-operation program `grasp` with the gripper: at the grasp pose the fingers
    close (force-limited, they stop on the part), the part is lifted `pick.lift_m`, held
    `pick.hold_s`, put down at the grasp pose and released. Moments for the run: the grasp
    pose (fingers open around the part), "pick: closed", "pick: lifted", "pick: placed"."""
    change_tool_safely(controller, "gripper")
    controller.set_gripper(pick.open_m)
    T_base_touch = grasp.operations[0].T_base_touch
    T_base_lift = T_base_touch.copy()
    T_base_lift[2, 3] += pick.lift_m

    def pick_and_put_down(name: str) -> None:
        # The fingers grip and carry the part: the supervision would take the grip for a
        # collision; it is off from the closing to the release, as a program turns the
        # collision detection off around a grip.
        with controller.supervision_off():
            hooks.moment(name, "gripper")
            controller.set_gripper(0.0)
            hooks.moment("pick: closed", "gripper")
            controller.move_linear(T_base_lift, speed_m_s=pick.speed_m_s, settle_s=pick.hold_s)
            hooks.moment("pick: lifted", "gripper")
            hooks.moved("lift")
            controller.move_linear(T_base_touch, speed_m_s=pick.speed_m_s)
            controller.set_gripper(pick.open_m)

    execute_program(
        controller, grasp, pick.speed_m_s, on_touch=pick_and_put_down, on_move=hooks.moved
    )
    hooks.moment("pick: placed", "gripper")
