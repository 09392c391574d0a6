"""The cell: MuJoCo build, physics, controller API, sensors, tool changer, kinematics.

`make_cell(config)` returns the controller (what a robot program sees) and the truth (what
only an evaluator reads); `VirtualCell` is the nominal cell, posed without physics, that a
program is checked for collisions in before it moves.
"""

from cell.config import (
    ArmErrors,
    CellConfig,
    DriveErrors,
    EncoderNoise,
    FixedMesh,
    FixedPrimitive,
    IRConfig,
    LaserConfig,
    LooseMesh,
    LoosePart,
    TableErrors,
    ToolErrors,
)
from cell.controller import Controller, nominal_T_base_slot, nominal_T_base_table
from cell.errors import (
    CellConfigError,
    CellError,
    JointLimitError,
    SupervisionError,
    ToolChangerError,
    UnknownNameError,
    UnreachableTargetError,
)
from cell.factory import make_cell, nominal_kinematics
from cell.kinematics import IKResult, Kinematics
from cell.laser import laser_points_base, points_in_table_frame
from cell.robots import ur5_kinematics
from cell.sensors import LaserReading
from cell.truth import CellTruth
from cell.virtual import Contact, VirtualCell

__all__ = [
    "ArmErrors",
    "CellConfig",
    "CellConfigError",
    "CellError",
    "CellTruth",
    "Contact",
    "Controller",
    "DriveErrors",
    "EncoderNoise",
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
    "SupervisionError",
    "TableErrors",
    "ToolChangerError",
    "ToolErrors",
    "UnknownNameError",
    "UnreachableTargetError",
    "VirtualCell",
    "laser_points_base",
    "make_cell",
    "nominal_T_base_slot",
    "nominal_T_base_table",
    "nominal_kinematics",
    "points_in_table_frame",
    "ur5_kinematics",
]
