"""The cell as a controller's user sees it: the controller API, its readings, the arm's data
sheets and nominal kinematics, the cell's layout, and the virtual cell.

`Controller` is what a robot program drives; `VirtualCell` is the nominal cell, posed without
physics, that a program is checked for collisions in before it moves. The simulated real
cell that implements the controller, and its truth, are `cell.sim`'s: nothing here imports
them.
"""

from cell.cell_errors import (
    CellConfigError,
    CellError,
    JointLimitError,
    MotionHaltedError,
    SupervisionError,
    ToolChangerError,
    UnknownNameError,
    UnreachableTargetError,
)
from cell.controller import (
    Controller,
    ControllerEvent,
    SupervisionLimits,
    nominal_T_base_slot,
    nominal_T_base_table,
)
from cell.irb2400_arm import nominal_kinematics
from cell.kinematics import IKResult, Kinematics
from cell.laser import laser_points_base, points_in_table_frame
from cell.layout import (
    CellLayout,
    FixedMesh,
    FixedPrimitive,
    IRConfig,
    LaserConfig,
    LooseMesh,
    LoosePart,
)
from cell.readings import LaserReading
from cell.robot_arm import Robot
from cell.ur5_arm import ur5_kinematics
from cell.virtual import Contact, VirtualCell

__all__ = [
    "CellConfigError",
    "CellError",
    "CellLayout",
    "Contact",
    "Controller",
    "ControllerEvent",
    "FixedMesh",
    "FixedPrimitive",
    "IKResult",
    "IRConfig",
    "JointLimitError",
    "Kinematics",
    "LaserConfig",
    "LaserReading",
    "LooseMesh",
    "LoosePart",
    "MotionHaltedError",
    "Robot",
    "SupervisionError",
    "SupervisionLimits",
    "ToolChangerError",
    "UnknownNameError",
    "UnreachableTargetError",
    "VirtualCell",
    "laser_points_base",
    "nominal_T_base_slot",
    "nominal_T_base_table",
    "nominal_kinematics",
    "points_in_table_frame",
    "ur5_kinematics",
]
