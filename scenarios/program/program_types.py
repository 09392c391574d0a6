"""The offline program as a value: a touch operation as authored on the virtual model
(`Operation`, in the OBJECT frame), the operation corrected and solved (`PlannedOperation`),
the corrected program (`OfflineProgram`), and what the controller measured at a touch
(`ExecutedOperation`). Made by scenarios.offline.program_plan, written as RAPID by
scenarios.rapid.writer."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cell import nominal_T_base_table


@dataclass(frozen=True)
class Operation:
    """A touch operation: the tool pose at touch in the object frame (4, 4), z into the
    object, and the approach distance back along z [m]; or, for a program written elsewhere,
    the approach pose itself (`T_object_approach_as_written`, 4 x 4)."""

    name: str
    T_object_touch: np.ndarray
    approach_m: float
    T_object_approach_as_written: np.ndarray | None = None

    @property
    def T_object_approach(self) -> np.ndarray:
        if self.T_object_approach_as_written is not None:
            return np.array(self.T_object_approach_as_written)
        T = self.T_object_touch.copy()
        T[:3, 3] -= self.approach_m * T[:3, 2]
        return T


@dataclass(frozen=True)
class PlannedOperation:
    """An operation corrected and solved: the tool's spin about its axis [rad] chosen for the
    arm, the poses in the base frame (4, 4), and the joint solutions (6,) [rad]."""

    operation: Operation
    spin_rad: float
    T_object_touch: np.ndarray
    T_object_approach: np.ndarray
    T_base_approach: np.ndarray
    T_base_touch: np.ndarray
    q_approach: np.ndarray
    q_touch: np.ndarray


@dataclass(frozen=True)
class OfflineProgram:
    """The corrected program: the tool, the table position [m], the object pose it was
    corrected with (4, 4, in the nominal table frame), and the planned operations."""

    tool: str
    table_position_m: float
    T_table_object: np.ndarray
    operations: tuple[PlannedOperation, ...]
    T_base_table: np.ndarray | None = None

    @property
    def T_base_object(self) -> np.ndarray:
        """(4, 4) the corrected object pose in the base frame at the program's table position
        (the table frame as the cell's model has it there; default the nominal)."""
        T = self.T_base_table
        return (nominal_T_base_table(self.table_position_m) if T is None else T) @ (
            self.T_table_object
        )


@dataclass(frozen=True)
class ExecutedOperation:
    """What the controller measured at the touch: the TCP (4, 4) from the encoders with the
    nominal kinematics, and the controller time [s]."""

    name: str
    T_base_tcp_measured: np.ndarray
    time_s: float
