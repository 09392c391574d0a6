"""How the files of examples/my_cell were made (rerun it to make them again).

    python examples/make_my_cell.py

- `phantom.ply`: the skull phantom's design (twincell's built-in model), decimated to 24,000
  triangles as a user's own mesh of their phantom would be, in mm;
- `burr_holes.mod`: the RAPID module a programmer writes for the virtual cell, by
  `twincell author` (its Python form, `author_program`): the work object on the phantom's
  nominal pose in `job.yaml` (the table at 0), and for each burr hole of the design a touch
  along the hole's axis, the pointer's 3 mm ball stopping 1 mm before the entry on the mesh
  and its approach 60 mm back, each checked in the virtual cell before it is written.
`cell.yaml`, `job.yaml` and `test_my_cell.py` are written by hand.
"""

from __future__ import annotations

from pathlib import Path

import trimesh

from models.registry import builtin_model
from scenarios.configuration.config_files import load_config
from scenarios.jobs.program_authoring import TouchRequest, author_program

HERE = Path(__file__).resolve().parent / "my_cell"


def write_mesh() -> None:
    skull = builtin_model("skull", 0)
    mesh = trimesh.Trimesh(skull.mesh.vertices * 1e3, skull.mesh.faces, process=True)
    mesh.simplify_quadric_decimation(face_count=24000).export(HERE / "phantom.ply")


def write_program() -> None:
    config = load_config(HERE / "job.yaml", cell=HERE / "cell.yaml")
    design = builtin_model("skull", 0)
    touches = [TouchRequest(h.name, h.p_entry, h.direction) for h in design.burr_holes]
    program = author_program(config, touches, module="BurrHoles", say=print)
    (HERE / "burr_holes.mod").write_text(program.text)


if __name__ == "__main__":
    write_mesh()
    write_program()
    print(f"wrote {HERE / 'phantom.ply'} and {HERE / 'burr_holes.mod'}")
