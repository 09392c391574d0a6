"""How the files of examples/my_cell were made (rerun it to make them again).

    python examples/make_my_cell.py

- `phantom.ply`: the skull phantom's design (twincell's built-in model), decimated to 24,000
  triangles as a user's own mesh of their phantom would be, in mm;
- `burr_holes.mod`: the RAPID module a programmer writes for the virtual cell (as in
  RobotStudio): the work object on the phantom's nominal pose in `job.yaml` (the table at
  0), and for each burr hole an approach 60 mm back along its axis and a touch that stops
  the pointer's 3 mm ball 1 mm before the entry on the mesh; each robtarget's configuration
  data is the arm's own solution (as `cell.yaml` sets it up).
`cell.yaml`, `job.yaml` and `test_my_cell.py` are written by hand.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from cell import nominal_T_base_table
from cell.robots import make_robot
from models.registry import builtin_model, load_model
from models.targets import frame_from_z
from registration.shapes.mesh_shape import MeshModel
from scenarios.configuration.config_files import load_config
from scenarios.offline.nominal_placement import nominal_pose
from scenarios.rapid.oframe import pose_text
from scenarios.rapid.writer import configuration

HERE = Path(__file__).resolve().parent / "my_cell"
BALL_RADIUS_M = 0.003  # the pointer's tip ball; its centre is the TCP
GAP_M = 0.001  # the ball stops this far before the entry
APPROACH_M = 0.06
EAX = "[0,9E+09,9E+09,9E+09,9E+09,9E+09]"


def write_mesh() -> None:
    skull = builtin_model("skull", 0)
    mesh = trimesh.Trimesh(skull.mesh.vertices * 1e3, skull.mesh.faces, process=True)
    mesh.simplify_quadric_decimation(face_count=24000).export(HERE / "phantom.ply")


def _entry_depth(model: MeshModel, p_entry: np.ndarray, direction: np.ndarray) -> float:
    """How far along the hole's axis the mesh's surface lies from the design's entry [m]."""
    steps = np.linspace(-0.003, 0.003, 601)
    points = p_entry + steps[:, None] * direction
    closest = model.closest(points)
    return float(steps[int(np.argmin(closest.distances))])


def write_program() -> None:
    config = load_config(HERE / "job.yaml", cell=HERE / "cell.yaml")
    phantom, _ = load_model(HERE / "phantom.ply", units="mm")
    design = builtin_model("skull", 0)
    T_base_object = nominal_T_base_table(0.0) @ nominal_pose(
        config.cell.object.placement, phantom.mesh.vertices
    )
    robot_section = config.cell.robot
    robot = make_robot(
        robot_section.model,
        robot_section.flange,
        robot_section.mount_xyz,
        q_home=None if robot_section.home_deg is None else np.radians(robot_section.home_deg),
        vendor=robot_section.vendor,
    )
    kin = robot.kinematics().for_tool("screwer")
    surface = MeshModel(phantom.mesh.vertices, phantom.mesh.faces)
    lines = [
        "MODULE BurrHoles",
        "  ! The phantom's burr-hole entries touched with the pointer, programmed on the",
        "  ! virtual cell: the work object on the phantom's nominal pose (table at 0).",
        "  PERS tooldata tPointer := [TRUE,[[0,0,200],[1,0,0,0]],[2,[0,0,100],[1,0,0,0],0,0,0]];",
        f'  PERS wobjdata wobjPhantom := [FALSE,TRUE,"",{pose_text(T_base_object)},'
        "[[0,0,0],[1,0,0,0]]];",
        "  CONST speeddata vTouch := [20,500,5000,1000];",
    ]
    T_flange_tcp = np.eye(4)
    T_flange_tcp[2, 3] = 0.2
    q = robot.q_home
    for k, hole in enumerate(design.burr_holes):
        axis = hole.direction / np.linalg.norm(hole.direction)
        entry = hole.p_entry + _entry_depth(surface, hole.p_entry, axis) * axis
        T_touch = frame_from_z(entry - (GAP_M + BALL_RADIUS_M) * axis, axis)
        T_approach = T_touch.copy()
        T_approach[:3, 3] -= APPROACH_M * axis
        for name, T in ((f"pApp{k}", T_approach), (f"pTouch{k}", T_touch)):
            q = kin.solve(T_base_object @ T, q, T_flange_tcp, extra_seeds=30)
            conf = ",".join(str(v) for v in configuration(kin, q))
            lines.append(f"  CONST robtarget {name} := [{pose_text(T)[1:-1]},[{conf}],{EAX}];")
    # The corrected work object turns the phantom by up to its fixture's 20 degrees: a target
    # may then need the wrist in another quadrant (configuration monitoring would stop).
    lines += ["  PROC main()", "    ConfJ\\Off;", "    ConfL\\Off;"]
    for k, hole in enumerate(design.burr_holes):
        lines += [
            f"    ! {hole.name}",
            f"    MoveJ pApp{k}, v500, z10, tPointer\\WObj:=wobjPhantom;",
            f"    MoveL pTouch{k}, vTouch, fine, tPointer\\WObj:=wobjPhantom;",
            f"    MoveL pApp{k}, v100, z10, tPointer\\WObj:=wobjPhantom;",
        ]
    lines += ["  ENDPROC", "ENDMODULE", ""]
    (HERE / "burr_holes.mod").write_text("\n".join(lines))


if __name__ == "__main__":
    write_mesh()
    write_program()
    print(f"wrote {HERE / 'phantom.ply'} and {HERE / 'burr_holes.mod'}")
