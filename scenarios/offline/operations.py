"""The operations of a job as the offline programmer authored them on the virtual model.

A target is an entry point on the object and a direction into it (a burr hole's trajectory,
a screw's axis), in the model frame. `touch` and `screw` operations put the tool tip a little
before the entry, its axis along the direction; a pick grasps the part at one of its
operation frames.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from models import BurrHole, ObjectModel, load_model
from scenarios.errors import ScenarioError
from scenarios.jobs.config import ObjectSection, OperationsSection, Pick
from scenarios.offline.program import Operation, burr_hole_operations
from scenarios.offline.targets import generate_targets, read_targets, targets_path


class OperationsError(ScenarioError, ValueError):
    """The object has no targets for the operations asked of it."""


def screw_targets(model: ObjectModel) -> tuple[BurrHole, ...]:
    """The part's screw frames driven from above (z within 25 deg of straight down), as
    targets: entry at the frame's origin, direction its z axis, 10 mm deep."""
    holes = []
    for frame in model.frames:
        z = frame.T_part_frame[:3, 2]
        if frame.kind == "screw" and z[2] < -0.9:
            holes.append(BurrHole(frame.name, frame.T_part_frame[:3, 3], z, 0.01))
    return tuple(holes)


def virtual_model(section: ObjectSection, kind: str, seed: int) -> ObjectModel:
    """The virtual model of the job's object with its targets for operations of `kind`:
    burr holes for touches (the model's own, `targets_file`, a `<mesh>.targets.yaml` beside
    a mesh file, or generated on its upper surface), screw frames driven from above for
    screws."""
    model, _warnings = load_model(section.model, seed=seed, units=section.units)
    if kind == "screw":
        holes = screw_targets(model)
        if not holes:
            raise OperationsError(
                f"model {model.name!r} has no screw frame driven from above; its frames are "
                f"{[f.name for f in model.frames]}"
            )
        return replace(model, burr_holes=holes)
    if section.targets_file is not None:
        return replace(model, burr_holes=read_targets(section.targets_file, section.units))
    if model.burr_holes:
        return model
    beside = targets_path(section.model)
    holes = read_targets(beside, section.units) if beside.is_file() else None
    return replace(model, burr_holes=holes or generate_targets(model, seed=seed))


def target_operations(model: ObjectModel, section: OperationsSection) -> tuple[Operation, ...]:
    """One operation per target of the model: the tool tip `touch_offset_m` before the entry
    on the trajectory, the tool axis along it, approached from `approach_m` back."""
    return burr_hole_operations(model.burr_holes, section.approach_m, section.touch_offset_m)


def grasp_operation(model: ObjectModel, pick: Pick) -> Operation:
    """The grasp: the part's operation frame `pick.frame` turned `pick.turn_deg` about its z
    (the fingers close across the part), approached from `pick.approach_m` back."""
    T = np.array(model.frame(pick.frame).T_part_frame)
    a = np.deg2rad(pick.turn_deg)
    Rz = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    T[:3, :3] = T[:3, :3] @ Rz
    return Operation(pick.frame, T, pick.approach_m)
