"""The simulated real cell: its MuJoCo physics, the errors it draws, the faults it has, the
controller that drives it, and its truth.

`make_cell(config)` returns the controller (cell.controller's API, what a robot program sees)
and the truth (what only an evaluator reads). Planning code never imports this package.
"""

from cell.sim.config import (
    ArmErrors,
    CellConfig,
    DriveErrors,
    EncoderNoise,
    TableErrors,
    ToolErrors,
)
from cell.sim.factory import make_cell
from cell.sim.faults import Fault
from cell.sim.sim_controller import SimController
from cell.sim.truth import CellTruth

__all__ = [
    "ArmErrors",
    "CellConfig",
    "CellTruth",
    "DriveErrors",
    "EncoderNoise",
    "Fault",
    "SimController",
    "TableErrors",
    "ToolErrors",
    "make_cell",
]
