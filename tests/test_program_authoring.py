"""A touch program authored on a job's virtual cell (`twincell author`, `author_program`): the
touches where the user named them on the part, solved on the nominal arm, checked in the
virtual cell, and refused with what to change where the arm cannot make them; the cell's
numbers as the code builds the cell."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

from cell import nominal_T_base_table
from models.robot import TOOLS
from scenarios.cli.app import main
from scenarios.cli.author_command import TouchSyntaxError, parse_touch
from scenarios.configuration.config_files import load_config
from scenarios.jobs.cell_numbers import cell_numbers
from scenarios.jobs.job_plan import job_robot
from scenarios.jobs.program_authoring import AuthoringError, TouchRequest, author_program
from scenarios.offline.nominal_placement import nominal_pose
from scenarios.rapid.task import read_task

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "my_cell"
#: Points of the example's phantom mesh (phantom.ply, mm): its crown, its brow (the face's
#: front) and its right temple (a side, the tool coming in sideways).
CROWN, BROW, TEMPLE = (-6.8, 0.16, 76.4), (62.5, 0.85, 55.1), (-0.74, -48.6, 56.9)
#: The phantom's lowest face (its normal down), 4 mm above the table top.
UNDER = (74.74, 1.17, -107.95)
BALL_M, GAP_M, APPROACH_M = 0.003, 0.001, 0.06


@pytest.fixture(scope="module")
def config():
    return load_config(EXAMPLE / "job.yaml", cell=EXAMPLE / "cell.yaml")


@pytest.fixture(scope="module")
def phantom() -> trimesh.Trimesh:
    """The part's mesh in metres, read by trimesh (not by the code under test)."""
    mesh = trimesh.load(EXAMPLE / "phantom.ply", force="mesh")
    mesh.apply_scale(1e-3)
    return mesh


def _requests(*named: tuple[str, tuple[float, float, float]]) -> list[TouchRequest]:
    return [TouchRequest(name, np.array(p) * 1e-3) for name, p in named]


def test_touches_stop_the_ball_short_of_the_surface_along_its_normal(config, phantom) -> None:
    """Each touch's TCP lies ball + gap (4 mm) from the mesh, within 0.05 mm, on the inward
    normal of the surface at the named point (within 3 deg of its faces' within 1 mm); its
    approach 60 mm back along the tool's axis; its joints put the nominal arm's TCP there
    (1 um); the side touch comes in sideways; the program passes the virtual cell from home."""
    program = author_program(
        config, _requests(("crown", CROWN), ("brow", BROW), ("temple", TEMPLE))
    )
    robot = job_robot(config.cell.robot)
    kin = robot.kinematics().for_tool("screwer")
    T_tcp = next(t for t in TOOLS if t.name == "screwer").T_tool_tcp
    T_base_object = nominal_T_base_table(0.0) @ nominal_pose(
        config.planning().placement, phantom.vertices
    )
    assert np.allclose(program.T_base_uframe, T_base_object, atol=1e-9)
    assert program.check.ok
    # The surface sampled every ~0.1 mm: a sample's distance errs by < 2 um at 4 mm.
    samples, faces = trimesh.sample.sample_surface(phantom, 2_000_000, seed=0)
    tree = cKDTree(samples)
    for touch in program.touches:
        T_touch, T_app = touch.planned.T_object_touch, touch.planned.T_object_approach
        distance, _ = tree.query(T_touch[:3, 3])
        assert distance == pytest.approx(BALL_M + GAP_M, abs=5e-5), touch.request.name
        near = tree.query_ball_point(touch.p_surface_m, 1e-3)  # the surface there, by area
        inward = -phantom.face_normals[faces[near]].mean(axis=0)
        inward /= np.linalg.norm(inward)
        assert np.degrees(np.arccos(np.clip(inward @ T_touch[:3, 2], -1, 1))) < 3.0
        assert np.allclose(T_app[:3, 3], T_touch[:3, 3] - APPROACH_M * T_touch[:3, 2], atol=1e-9)
        for T_object, q in ((T_touch, touch.planned.q_touch), (T_app, touch.planned.q_approach)):
            reached = kin.fk(q) @ T_tcp
            assert np.allclose(reached[:3, 3], (T_base_object @ T_object)[:3, 3], atol=1e-6)
    temple = program.touches[2]
    assert abs(temple.planned.T_object_touch[2, 2]) < 0.8  # more sideways than down


def test_the_written_module_reads_back_as_the_touches(config, tmp_path) -> None:
    """The module twincell's RAPID reader reads back has the authored touches (names, poses
    within the text's 0.1 um) and the work object on the part's nominal pose."""
    program = author_program(config, _requests(("crown", CROWN), ("temple", TEMPLE)))
    path = tmp_path / "touches.mod"
    path.write_text(program.text)
    module = read_task([path]).modules[0]
    assert list(module.wobjs) == ["wobjPart"]
    wobj = module.wobjs["wobjPart"]
    assert np.allclose(wobj.T_base_uframe, program.T_base_uframe, atol=1e-6)
    for touch in program.touches:
        written = module.targets[touch.touch_name].T_wobj_tcp
        assert np.allclose(written[:3, 3], touch.planned.T_object_touch[:3, 3], atol=1e-6)


def test_a_touch_the_arm_cannot_make_is_refused_with_what_to_change(config) -> None:
    """A touch from below (the part's lowest face, 4 mm above the table top) is refused
    after every spin of the tool, naming the touch and what to change."""
    with pytest.raises(AuthoringError) as caught:
        author_program(config, _requests(("under", UNDER)))
    text = str(caught.value)
    assert "touch under" in text and "12 tried" in text and "another direction" in text


def test_named_points_off_the_surface_are_refused(config) -> None:
    """Refused as asked, with no search for another order, table or turn (none would put the
    point on the surface)."""
    said: list[str] = []
    with pytest.raises(AuthoringError, match=r"touch far: the point .* lies 2\d\.\d mm from"):
        author_program(config, _requests(("far", (-6.8, 0.16, 100.0))), say=said.append)
    assert not [line for line in said if "looking for" in line], said
    with pytest.raises(AuthoringError, match="does not meet the part's surface within 3 mm"):
        author_program(
            config, [TouchRequest("miss", np.array([0.0, 0.0, 0.2]), np.array([1.0, 0, 0]))]
        )
    with pytest.raises(AuthoringError, match="touch names must differ"):
        author_program(config, _requests(("a", CROWN), ("a", BROW)))


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("crown", "write NAME=X,Y,Z"),
        ("crown=1,2", "the point must be three numbers"),
        ("crown=1,2,x", "the point must be three numbers"),
        ("crown=1,2,3@0,0", "the direction must be three numbers"),
        ("crown=1,2,3@0,0,0", "the direction must not be zero"),
        ("9lives=1,2,3", "write NAME=X,Y,Z"),
    ],
)
def test_touch_syntax(text: str, message: str) -> None:
    with pytest.raises(TouchSyntaxError, match=message):
        parse_touch(text, 1e-3)


def test_touch_parses_in_the_given_units() -> None:
    name, point, direction = parse_touch(" side = 80, 10.5,60 @ -1,0,0 ", 1e-3)
    assert name == "side" and np.allclose(point, [0.08, 0.0105, 0.06])
    assert direction is not None and np.allclose(direction, [-1, 0, 0])


def test_command_writes_the_module_whole_or_not_at_all(tmp_path, capsys) -> None:
    """`twincell author` writes the module and says how to run it; a refused touch writes
    nothing and exits 2 with one line."""
    job = ["author", str(EXAMPLE / "job.yaml"), "--cell", str(EXAMPLE / "cell.yaml")]
    out = tmp_path / "mine.mod"
    crown = "--touch=crown=" + ",".join(map(str, CROWN))
    assert main([*job, crown, "--out", str(out), "--quiet"]) == 0
    said = capsys.readouterr().out
    assert "pCrown: the surface at" in said and f"--program {out}" in said
    assert out.read_text().startswith("MODULE Touches") and out.read_text().endswith("ENDMODULE\n")
    refused = tmp_path / "refused.mod"
    under = "--touch=under=" + ",".join(map(str, UNDER))
    assert main([*job, crown, under, "--out", str(refused), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("twincell:") and "touch under" in err and "\n" not in err
    assert not refused.exists() and list(tmp_path.iterdir()) == [out]


def test_cell_numbers_come_from_the_cell(config) -> None:
    """The work object row is the part's nominal pose as the run's check expects it; the
    table's row the nominal table; the arm's home the cell file's."""
    numbers = {n.quantity: n.value for n in cell_numbers(config)}
    table = numbers["table frame (top surface's centre) in the cell frame, table at 0"]
    assert table.startswith("[1150, 0, 400] mm")
    wobj = next(v for k, v in numbers.items() if k.startswith("work object (RAPID)"))
    assert wobj == '[FALSE,TRUE,"",[[1150,0,512.0851],[0.5,0,0,0.8660254]],[[0,0,0],[1,0,0,0]]]'
    assert numbers["the arm's home (every job starts and ends there)"] == "[0, 0, 0, 0, 90, 0] deg"


def test_an_oblique_touch_keeps_its_ball_off_the_surface(config, phantom) -> None:
    """The crown touched 45 deg off its normal: along the axis the ball stops farther back than
    ball + gap (4 mm), so that it stays at least 0.5 mm off the surface (its centre 3.5 mm
    from the surface sampled here, within 0.05 mm; more where the crown curves away); 80 deg
    off is refused as too oblique."""
    normal = np.array([-0.063, 0.014, -0.998])  # the crown's inward normal (printed by author)
    side = np.cross(normal, [1.0, 0.0, 0.0])
    side /= np.linalg.norm(side)
    for degrees, ok in ((45.0, True), (80.0, False)):
        a = np.radians(degrees)
        direction = np.cos(a) * normal + np.sin(a) * side
        request = TouchRequest("crown", np.array(CROWN) * 1e-3, direction)
        if not ok:
            with pytest.raises(AuthoringError, match="more than 70: give a direction nearer"):
                author_program(config, [request])
            continue
        touch = author_program(config, [request]).touches[0]
        samples, _ = trimesh.sample.sample_surface(phantom, 2_000_000, seed=1)
        centre = touch.planned.T_object_touch[:3, 3]
        distance, _ = cKDTree(samples).query(centre)
        assert distance >= BALL_M + 5e-4 - 5e-5
        assert np.linalg.norm(centre - touch.p_surface_m) > BALL_M + GAP_M + 5e-4
