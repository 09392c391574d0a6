"""The cell's model files: IRB2000-class arm, sliding table, tools, rack, tool changer.

`irb2400.xml` (robot only, parsed by Pinocchio and MuJoCo) and `scene.xml` (the cell, which
includes it) are written by `python -m models.robot.generate` from the generators here.
"""

from models.robot.arm import (
    BODY_NAMES,
    FLANGE_SITE,
    JOINT_LOWER,
    JOINT_NAMES,
    JOINT_SPEED,
    JOINT_TORQUE,
    JOINT_UPPER,
    Q_HOME,
    ArmGeometry,
    arm_xml,
)
from models.robot.paths import MODEL_DIR, ROBOT_PATH, SCENE_PATH
from models.robot.scene_mjcf import ROBOT_FILE, TIMESTEP, scene_xml
from models.robot.tools import (
    FINGER_TRAVEL,
    GRIPPER,
    IR,
    LASER,
    RACK_POS,
    SCREWER,
    SLOT_QUAT,
    TOOL_GROUP,
    TOOLS,
    ToolSpec,
    beam_line,
    slot_pos,
)
from models.robot.worktable import (
    TABLE_GUIDE_JOINTS,
    TABLE_HALF,
    TABLE_SPEED,
    TABLE_TOP_POS,
    TABLE_TRAVEL,
)

__all__ = [
    "BODY_NAMES",
    "FINGER_TRAVEL",
    "FLANGE_SITE",
    "GRIPPER",
    "IR",
    "JOINT_LOWER",
    "JOINT_NAMES",
    "JOINT_SPEED",
    "JOINT_TORQUE",
    "JOINT_UPPER",
    "LASER",
    "MODEL_DIR",
    "Q_HOME",
    "RACK_POS",
    "ROBOT_FILE",
    "ROBOT_PATH",
    "SCENE_PATH",
    "SCREWER",
    "SLOT_QUAT",
    "TABLE_GUIDE_JOINTS",
    "TABLE_HALF",
    "TABLE_SPEED",
    "TABLE_TOP_POS",
    "TABLE_TRAVEL",
    "TIMESTEP",
    "TOOLS",
    "TOOL_GROUP",
    "ArmGeometry",
    "ToolSpec",
    "arm_xml",
    "beam_line",
    "scene_xml",
    "slot_pos",
]
