"""The operations of a job as the offline programmer authored them on the virtual model.

A target is an entry point on the object and a direction into it (a burr hole's trajectory,
a screw's axis), in the model frame. `touch` and `screw` operations put the tool tip a little
before the entry, its axis along the direction; a pick grasps the part at one of its
operation frames.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from models.ct.object import volume_object
from models.ct.readers import is_volume
from models.ct.regular import MAX_GAP_MM
from models.model import ObjectModel
from models.registry import load_model
from models.targets import BurrHole
from registration.rigid import pose_error
from scenarios.offline.mesh_targets import UP, generate_targets, read_targets, targets_path
from scenarios.offline.program_plan import burr_hole_operations
from scenarios.offline.settings import OperationsSection, Pick
from scenarios.program.program_types import Operation
from scenarios.rapid.module import RapidModule, WobjData
from scenarios.rapid.oframe import pose_text
from scenarios.rapid.syntax import RapidError
from scenarios.rapid.task import ENCRYPTED_KEPT, UNDEFINED_CALL, RapidTask, read_task
from scenarios.rapid.touches import TouchOperation, folded, touch_operations
from scenarios.scenario_errors import ScenarioError

#: Where a job's object's units are set: its configuration key (`twincell run --model FILE
#: --units mm` sets it too).
UNITS_KEY = "cell.object.units"
#: A user program's work object must describe the object's nominal pose this closely [m],
#: [deg]: the program and the job then speak of the same virtual cell.
WOBJ_TOLERANCE_M = 2e-3
WOBJ_TOLERANCE_DEG = 1.0


class OperationsError(ScenarioError, ValueError):
    """The object has no targets for the operations asked of it."""


def screw_targets(model: ObjectModel, up_model: np.ndarray = UP) -> tuple[BurrHole, ...]:
    """The part's screw frames driven from above (z within 25 deg of straight down; up is
    `up_model` (3,), the table's vertical in the model frame), as targets: entry at the
    frame's origin, direction its z axis, 10 mm deep."""
    holes = []
    for frame in model.frames:
        z = frame.T_part_frame[:3, 2]
        if frame.kind == "screw" and z @ up_model < -0.9:
            holes.append(BurrHole(frame.name, frame.T_part_frame[:3, 3], z, 0.01))
    return tuple(holes)


def virtual_model(
    name: str,
    units: str,
    targets_file: str | None,
    kind: str,
    seed: int,
    iso_hu: float = 300.0,
    ct_voxel_mm: tuple[float, float, float] | None = None,
    ct_max_gap_mm: float = MAX_GAP_MM,
    use_cache: bool = True,
    up_model: np.ndarray = UP,
) -> ObjectModel:
    """The virtual model of the object `name` (built in, a mesh file in `units`, or a CT
    volume) with its targets for operations of `kind`: burr holes for touches (the model's
    own, `targets_file`, a `<mesh>.targets.yaml` beside a mesh file, or generated on its
    upper surface), screw frames driven from above for screws; up is `up_model` (3,), the
    table's vertical in the model frame as the part lies. A CT volume's model is its
    bone at `iso_hu` [HU] (an irregular series resampled, at `ct_voxel_mm` if given; a slice
    gap wider than `ct_max_gap_mm` refused), and a JSON `targets_file` is the plan made on it
    (models.ct.volume_plan). `use_cache`: a built-in model may be read from the user's cache
    folder (models.cache)."""
    if is_volume(name):  # a CT: its bone, and the plan made on it
        json_plan = targets_file is not None and targets_file.lower().endswith(".json")
        plan = targets_file if json_plan else None
        model = volume_object(name, iso_hu, plan, seed, ct_voxel_mm, ct_max_gap_mm)
        if json_plan:
            return model
    else:
        model, _warnings = load_model(
            name, seed=seed, units=units, use_cache=use_cache, units_option=UNITS_KEY
        )
    if kind == "screw":
        holes = screw_targets(model, up_model)
        if not holes:
            raise OperationsError(
                f"model {model.name!r} has no screw frame driven from above; its frames are "
                f"{[f.name for f in model.frames]}"
            )
        return replace(model, burr_holes=holes)
    if targets_file is not None:
        return replace(model, burr_holes=read_targets(targets_file, units))
    if model.burr_holes:
        return model
    beside = targets_path(name)
    if beside.is_file():
        holes = read_targets(beside, units) or generate_targets(model, seed=seed, up_model=up_model)
        return replace(model, burr_holes=holes)
    return replace(model, burr_holes=generate_targets(model, seed=seed, up_model=up_model))


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


@dataclass(frozen=True, eq=False)
class UserProgram:
    """The user's RAPID program: the module whose moves hold the touches (its work object and
    robtargets as that module sees them in its task), the work object, the touch operations
    read from it, the table position its robtargets were taught at [m] (external axis A, 0 if
    unused), the targets' names (one per operation, as operations.names says), the task it
    belongs to (a task of that one module for a single file) and the module that declares the
    work object (the one written back corrected)."""

    module: RapidModule
    wobj: WobjData
    operations: tuple[TouchOperation, ...]
    table_position_m: float
    names: tuple[str, ...]
    task: RapidTask | None = None
    wobj_module: RapidModule | None = None


def read_user_program(section: OperationsSection) -> UserProgram:
    """Read the RAPID program of `section.program` (a module file, or a folder holding a
    task's modules) and its touch operations; raises RapidError (naming the file and the
    line) for a program that cannot be used: one that calls a procedure defined nowhere in
    its task (a controller does not load it; where the task holds encrypted modules, which may
    define it, the executor refuses the call where the program reaches it), or whose touches
    are spread over modules."""
    assert section.program is not None
    path = Path(section.program)
    if not path.exists():
        raise RapidError(f"RAPID program not found: {path}")
    task = read_task([path])
    unread = {f"{p}: {ENCRYPTED_KEPT}" for p in task.opaque}
    blocking = [w for w in task.warnings if w not in unread]
    if task.opaque:  # a routine called may be one of the encrypted modules'
        blocking = [w for w in blocking if UNDEFINED_CALL not in w]
    if blocking:
        raise RapidError(
            f"{blocking[0]}; a controller does not load a program that calls a routine "
            "it does not have"
        )
    used = {
        m.wobj.casefold(): m.wobj
        for module in task.modules
        for m in module.moves
        if m.wobj is not None and m.T_wobj_tcp is not None
    }
    wobj_name = section.wobj
    if wobj_name is None:
        if len(used) != 1:
            raise RapidError(
                f"{path}: its moves use the work objects {sorted(used.values()) or 'none'}; "
                "name the one that holds the object's targets (operations.wobj)"
            )
        wobj_name = next(iter(used.values()))
    module = _touch_module(task, wobj_name, path)
    operations = touch_operations(module, wobj_name, section.pairs)
    wobj = next(w for w in module.wobjs.values() if w.name.casefold() == wobj_name.casefold())
    if wobj.robhold or wobj.ufmec.strip():
        raise RapidError(
            f"{path}: line {wobj.line}: work object {wobj.name} is held by the robot or moved "
            f"by a mechanical unit ({wobj.ufmec!r}); a fixed user frame is needed"
        )
    eax = [t.eax[0] for t in module.targets.values() if t.eax[0] < 9e8]
    table_position_m = float(eax[0]) * 1e-3 if eax else 0.0
    declaring = next(
        (m for m in task.modules if any(n.casefold() == wobj.name.casefold() for n in m.wobjs)),
        module,
    )
    names = target_names(operations, section.names, path)
    return UserProgram(module, wobj, operations, table_position_m, names, task, declaring)


def target_names(
    operations: tuple[TouchOperation, ...], names: str | dict[str, str], path: Path
) -> tuple[str, ...]:
    """The targets' names of the program's `operations` as operations.names says: the touch
    robtargets' names ("robtargets"), a naming comment's where there is one ("comments"), or
    a table {robtarget: name}, the others keeping theirs. Raises RapidError for a table's
    robtarget that is no touch's, and for two touches named alike by comments or a table."""
    if names == "robtargets":
        return tuple(op.name for op in operations)
    if names == "comments":
        chosen = [op.comment or op.name for op in operations]
    else:
        assert isinstance(names, dict)
        table = {folded(key): value for key, value in names.items()}
        touches = {folded(op.name) for op in operations}
        unknown = [key for key in names if folded(key) not in touches]
        if unknown:
            raise RapidError(
                f"{path}: operations.names names {', '.join(unknown)}, not a touch robtarget "
                f"of the program (its touches: {', '.join(op.name for op in operations)})"
            )
        chosen = [table.get(folded(op.name), op.name) for op in operations]
    for i, name in enumerate(chosen):
        twin = next((j for j in range(i) if folded(chosen[j]) == folded(name)), None)
        if twin is not None:
            raise RapidError(
                f"{path}: the touches {operations[twin].name} (line {operations[twin].line}) "
                f"and {operations[i].name} (line {operations[i].line}) are both named {name} "
                "(operations.names); give each its own name"
            )
    return tuple(chosen)


def _touch_module(task: RapidTask, wobj: str, path: Path) -> RapidModule:
    """The module of `task` whose moves use work object `wobj`, with the work objects and
    robtargets it sees in its task (its own and the other modules' global ones)."""
    holders = [
        m
        for m in task.modules
        if any(x.wobj is not None and x.wobj.casefold() == wobj.casefold() for x in m.moves)
    ]
    if len(holders) > 1:
        raise RapidError(
            f"{path}: the moves with work object {wobj} are in the modules "
            f"{', '.join(m.name for m in holders)}; the run reads the touches of one module"
        )
    module = holders[0] if holders else task.modules[0]
    scope = task.scope(module)
    return replace(module, wobjs=scope.wobjs, targets=scope.targets)


def program_targets(program: UserProgram) -> tuple[BurrHole, ...]:
    """The user program's touches as targets, by their names (operations.names): the TCP at
    touch is the target, the tool's z axis its direction."""
    return tuple(
        BurrHole(name, op.T_wobj_touch[:3, 3], op.T_wobj_touch[:3, 2], 0.01)
        for op, name in zip(program.operations, program.names, strict=True)
    )


def program_operations(program: UserProgram) -> tuple[Operation, ...]:
    """The user program's touches as operations, by their targets' names, approach and touch
    poses as written."""
    return tuple(
        Operation(
            name,
            op.T_wobj_touch,
            float(np.linalg.norm(op.T_wobj_approach[:3, 3] - op.T_wobj_touch[:3, 3])),
            op.T_wobj_approach,
        )
        for op, name in zip(program.operations, program.names, strict=True)
    )


def check_program_frame(
    program: UserProgram,
    T_base_object_nominal: np.ndarray,
    tolerance_m: float = WOBJ_TOLERANCE_M,
    tolerance_deg: float = WOBJ_TOLERANCE_DEG,
) -> None:
    """The work object's object frame (uframe @ oframe) must be the object's nominal pose of
    the configuration: both describe the same virtual cell. Raises RapidError otherwise."""
    w = program.wobj
    T_program = w.T_base_uframe @ w.T_uframe_oframe
    rotation, translation = pose_error(T_program, T_base_object_nominal)
    if translation > tolerance_m or np.degrees(rotation) > tolerance_deg:
        raise RapidError(
            f"{program.module.path}: line {w.line}: the object frame of work object {w.name} "
            f"lies {translation * 1e3:.1f} mm and {np.degrees(rotation):.2f} deg from the "
            "object's nominal pose in the configuration (cell.object.placement, the table at "
            f"{program.table_position_m:.3f} m), where uframe @ oframe should be "
            f"{pose_text(T_base_object_nominal)} (`twincell author` writes the work object): "
            "the program and the configuration must describe the same virtual cell"
        )
