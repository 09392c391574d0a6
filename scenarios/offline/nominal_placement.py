"""Where the planner believes an object sits on the table: its nominal pose.

The object's orientation on the table is built in this order, each turn about the table's
axes: its model's up axis turned to the table's +z (`UP_TURNS`: a quarter turn about a
horizontal axis, a half turn about x for "-z", none for "+z"), then `roll_deg` about x,
`pitch_deg` about y, `yaw_deg` about z:

    R_table_object = Rz(yaw) @ Ry(pitch) @ Rx(roll) @ R_up

and the object rests on the table: its lowest vertex `lift_m` above the top.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from scenarios.offline.settings import NominalPlacement

#: R_up of each up axis: the rotation (exact, integer entries) that turns the model's up
#: axis to the table's +z. "+x": -90 deg about y; "-x": +90 deg about y; "+y": +90 deg about
#: x; "-y": -90 deg about x; "-z": 180 deg about x.
UP_TURNS: dict[str, np.ndarray] = {
    "+x": np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]),
    "-x": np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]]),
    "+y": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]),
    "-y": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]),
    "+z": np.eye(3),
    "-z": np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]),
}


def resting_pose(R: np.ndarray, xy: np.ndarray, vertices: np.ndarray, lift_m: float) -> np.ndarray:
    """(4, 4) T_table_object with rotation R, origin at `xy` and the lowest vertex `lift_m`
    above the table top."""
    z = -float(np.min(np.asarray(vertices) @ R[2])) + lift_m
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = [xy[0], xy[1], z]
    return T


def upright_rotation(placement: NominalPlacement) -> np.ndarray:
    """(3, 3) the object's orientation before its yaw: the up axis turned up, then rolled
    about the table's x and pitched about its y (the identity at the defaults)."""
    R_tilt = Rotation.from_euler(
        "xy", [placement.roll_deg, placement.pitch_deg], degrees=True
    ).as_matrix()
    return R_tilt @ UP_TURNS[placement.up_axis]


def yawed_rotation(placement: NominalPlacement, yaw_deg: float) -> np.ndarray:
    """(3, 3) R_table_object: the upright orientation turned `yaw_deg` about the vertical."""
    return Rotation.from_euler("z", yaw_deg, degrees=True).as_matrix() @ upright_rotation(placement)


def nominal_pose(placement: NominalPlacement, vertices_object: np.ndarray) -> np.ndarray:
    """(4, 4) the pose the planner believes: the up axis up, rolled, pitched and yawed about
    the table's axes, resting on it."""
    R = yawed_rotation(placement, placement.yaw_deg)
    return resting_pose(R, np.array(placement.xy_m), vertices_object, placement.lift_m)
