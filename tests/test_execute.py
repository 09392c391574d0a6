"""`twincell execute`: a run's program.mod run on the run's real cell as an IRC5 without
absolute accuracy (the arm's nominal kinematics), the touched targets measured against the
truth; the IK branch a robtarget's confdata asks for; bad programs refused before any motion.

Ground truth here is never produced by the executor: the true targets and the run's own
touches come from the run (results.json, written by the job's evaluator), the commanded
points from the module's numbers (read by the RAPID reader), the branches from joints the
test chooses itself and the arm's true joints from the cell's truth.
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from cell.controller import SETTLE_S
from cell.irb2400_arm import irb2400
from cell.sim import CellConfig, make_cell
from models.robot import TOOLS
from scenarios.cli.app import main
from scenarios.configuration.config_files import load_config
from scenarios.jobs.execute_run_folder import (
    execute_in_cell,
    job_program,
    job_targets,
    rebuild_job_cell,
)
from scenarios.jobs.job_plan import job_robot, object_models
from scenarios.rapid.executor import ExecutionError, execute_plan, run_move
from scenarios.rapid.planner import plan_execution
from scenarios.rapid.rapid_text import configuration
from scenarios.rapid.reader import read_module
from scenarios.rapid.syntax import RapidError

SHORT = """seed: 0
localization:
  scan: {speed_m_s: 0.25, period_s: 0.02}
export: {compensation: nominal, execute: false}
output: {rrd: false, plots: false}
"""
UNUSED = "[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]"


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A short skull run (seed 0) exporting the program as programmed (compensation
    nominal), then its program.mod executed by the command line."""
    root = tmp_path_factory.mktemp("execute")
    config = root / "short.yaml"
    config.write_text(SHORT)
    assert main(["run", str(config), "--out", str(root / "out"), "--quiet", "--no-rrd"]) == 0
    folder = (root / "out" / "latest").resolve()
    assert main(["execute", str(folder), "--quiet"]) == 0
    return folder


def _json(path: Path) -> dict:
    return json.loads(path.read_text())


def _line(text: str, fragment: str) -> int:
    """1-based number of the first line of `text` containing `fragment`."""
    return next(i for i, line in enumerate(text.splitlines(), 1) if fragment in line)


def _pose(T: np.ndarray) -> str:
    """[[x,y,z],[q1,q2,q3,q4]] of T in mm and a scalar-first quaternion."""
    q = Rotation.from_matrix(T[:3, :3]).as_quat(scalar_first=True)
    p = T[:3, 3] * 1e3
    return f"[[{p[0]:.4f},{p[1]:.4f},{p[2]:.4f}],[{','.join(f'{v:.10f}' for v in q)}]]"


def _robtarget(name: str, T: np.ndarray, conf: tuple[int, ...]) -> str:
    return f"  CONST robtarget {name} := [{_pose(T)[1:-1]},[{','.join(map(str, conf))}],{UNUSED}];"


# -- the run's program on the nominal arm --------------------------------------------------------
@pytest.mark.slow
def test_execution_json_is_complete_and_consistent(folder: Path) -> None:
    execution = _json(folder / "execution.json")
    results = _json(folder / "results.json")
    assert not list(folder.glob(".*"))  # written atomically: no temporary file left
    assert execution["status"] == "complete" and execution["program"] == "program.mod"
    assert execution["compensation"] == "nominal"  # as the module states it
    assert execution["controller"] == {"absolute_accuracy": False, "kinematics": "nominal"}
    assert execution["job"] == "short" and execution["seed"] == 0
    assert execution["tool"] == "screwer" and execution["table_position_m"] == 0.0
    assert execution["moves"] == 12 and execution["other_stops"] == []
    # Every target the run touched was touched again, in the program's order.
    assert [t["name"] for t in execution["targets"]] == [t["name"] for t in results["targets"]]
    module = (folder / "program.mod").read_text()
    for t in execution["targets"]:
        assert t["line"] == _line(module, f"MoveL {t['robtarget']},")
        gap = np.linalg.norm(np.subtract(t["p_achieved_base_m"], t["p_true_base_m"]))
        assert t["error_m"] == pytest.approx(gap, rel=1e-12)
    errors = np.array([t["error_m"] for t in execution["targets"]])
    assert execution["target_error_rms_m"] == pytest.approx(np.sqrt(np.mean(errors**2)))
    assert execution["target_error_max_m"] == pytest.approx(errors.max())
    assert execution["job_target_error_rms_m"] == results["target_error_rms_m"]
    assert execution["job_target_error_max_m"] == results["target_error_max_m"]
    assert execution["motion_time_s"] > 0
    assert all(execution["wall_time_s"][k] > 0 for k in ("plan", "cell", "execute", "total"))


@pytest.mark.slow
def test_the_executed_targets_are_the_run_s_true_targets(folder: Path) -> None:
    """The rebuilt cell is the run's: each true target where the run's evaluator had it (the
    table's per-move repeatability, 0.01 mm sigma, separates the two), and the program
    commanded the point of the module's numbers, uframe @ oframe @ robtarget."""
    execution = _json(folder / "execution.json")
    job = {t["name"]: t for t in _json(folder / "results.json")["targets"]}
    module = read_module(folder / "program.mod")
    w = module.wobjs["wobjObject"]
    for t in execution["targets"]:
        assert (
            np.linalg.norm(np.subtract(t["p_true_base_m"], job[t["name"]]["p_true_base_m"])) < 1e-4
        )
        T = w.T_base_uframe @ w.T_uframe_oframe @ module.targets[t["robtarget"]].T_wobj_tcp
        np.testing.assert_allclose(t["p_commanded_base_m"], T[:3, 3], atol=1e-12)
        # The registration's share is the commanded point's distance from the true target
        # (the robtargets are written to 0.1 um).
        gap = np.linalg.norm(np.subtract(t["p_commanded_base_m"], t["p_true_base_m"]))
        assert t["registration_error_m"] == pytest.approx(gap, abs=1e-6)


@pytest.mark.slow
def test_the_nominal_arm_misses_its_commanded_points_by_its_absolute_error(folder: Path) -> None:
    """The controller believes it put the TCP on each commanded point (its nominal FK of the
    encoders, within 0.1 mm: encoder noise of 1e-5 rad on a 1.3 m arm, and the servos), while
    the truth has it off by the real arm's deviation from its data sheet: at most 1.5 mm for
    this arm class, and more than the run's own execution with the arm it calibrated missed
    the same points by (that one keeps what the calibration cannot see: the tool's own TCP
    error, the drives' lost motion; seed 0: 0.42 mm against 0.34 mm). The two arms put the
    TCP in clearly different places."""
    execution = _json(folder / "execution.json")
    job = {t["name"]: t for t in _json(folder / "results.json")["targets"]}
    nominal, calibrated, apart = [], [], []
    for t in execution["targets"]:
        p = np.array(t["p_commanded_base_m"])
        assert np.linalg.norm(np.subtract(t["p_controller_base_m"], p)) < 1e-4
        nominal.append(np.linalg.norm(np.subtract(t["p_achieved_base_m"], p)))
        calibrated.append(np.linalg.norm(np.subtract(job[t["name"]]["p_achieved_base_m"], p)))
        apart.append(
            np.linalg.norm(np.subtract(t["p_achieved_base_m"], job[t["name"]]["p_achieved_base_m"]))
        )
    nominal_rms, calibrated_rms, apart_rms = np.sqrt(
        np.mean(np.square([nominal, calibrated, apart]), axis=1)
    )
    assert max(nominal) < 1.5e-3
    assert nominal_rms > calibrated_rms, (nominal_rms, calibrated_rms, apart_rms)
    # The two arms put the TCP in different places: far more than the table's and the
    # drives' repeatability (a few hundredths of a mm) that two runs of one arm differ by.
    assert apart_rms > 0.2e-3, (nominal_rms, calibrated_rms, apart_rms)


@pytest.mark.slow
def test_a_job_cell_runs_the_program_on_its_nominal_arm_whatever_its_option(folder: Path) -> None:
    """What a job can call at its end with the cell it built: its controller has the
    absolute-accuracy option set (here an arm 1 mm and 1 mrad off in every parameter), yet
    the program runs on the nominal arm, exactly as `twincell execute` ran it in a cell
    rebuilt from the same seed (the same figures to 1 nm), and the option is set back."""
    config = load_config(folder / "config.yaml")
    robot = job_robot(config.cell.robot)
    user = job_program(config, folder)
    virtual, real = object_models(config, user)
    cell = rebuild_job_cell(config, virtual, real, robot)
    other_arm = robot.kinematics(np.full(len(robot.parameters), 1e-3))
    cell.controller.set_absolute_accuracy(other_arm)
    result = execute_in_cell(
        cell, read_module(folder / "program.mod"), job_targets(config, virtual, user)
    )
    assert cell.controller.absolute_accuracy is other_arm
    cli = {t["name"]: t for t in _json(folder / "execution.json")["targets"]}
    assert [t.evaluation.name for t in result.targets] == list(cli)
    for t in result.targets:
        assert t.evaluation.error_m == pytest.approx(cli[t.evaluation.name]["error_m"], abs=1e-9)


# -- the IK branch of a robtarget's confdata -------------------------------------------------------
def test_a_robtarget_s_confdata_selects_its_branch_and_the_arm_goes_there() -> None:
    """One flange pose programmed three times: in the configuration of joints the test
    chooses, with the wrist flipped (cfx bit 0; axes 4 and 6 half a turn on) and with axis 6
    one turn on (cf6 + 4); then a straight move up that keeps the turned branch. The plan's
    joints are in each asked configuration and put the flange on the pose; the real arm's
    joints (the cell's truth) end there, within its drives' lost motion and sag."""
    robot = irb2400()
    kin = robot.kinematics()
    q_chosen = np.array([0.1, 0.3, 0.1, 0.4, -0.8, 0.5])
    q_flipped = q_chosen + np.array([0.0, 0.0, 0.0, -np.pi, 1.6, -np.pi])  # axis 5 to +0.8
    q_turned = q_chosen + np.array([0.0, 0.0, 0.0, 0.0, 0.0, 2 * np.pi])
    T = kin.fk(q_chosen)
    for q in (q_flipped, q_turned):  # the same pose, by hand
        np.testing.assert_allclose(kin.fk(q), T, atol=1e-12)
    confs = [configuration(kin, q) for q in (q_chosen, q_flipped, q_turned)]
    assert (
        len(set(confs)) == 3 and confs[1][3] == confs[0][3] ^ 1 and confs[2][2] == confs[0][2] + 4
    )
    text = "\n".join(
        [
            "MODULE Branches",
            "  ! compensation: filtered",
            _robtarget("pChosen", T, confs[0]),
            _robtarget("pFlipped", T, confs[1]),
            _robtarget("pTurned", T, confs[2]),
            "  PROC main()",
            "    MoveJ pChosen, v1000, fine, tool0;",
            '    TPWrite "other branches";',
            "    Others;",
            "  ENDPROC",
            "  PROC Others()",
            "    MoveJ pFlipped, v1000, fine, tool0;",
            "    MoveJ pTurned, v1000, z10, tool0;",
            "    MoveL Offs(pTurned, 0, 0, 50), v200, fine, tool0;",
            "  ENDPROC",
            "ENDMODULE",
            "",
        ]
    )
    module = read_module(text, "branches.mod")
    tools = {t.name: t.T_tool_tcp for t in TOOLS}
    plan = plan_execution(module, kin, tools, robot.q_home, robot.joint_speed)
    assert plan.compensation == "filtered" and plan.tool is None
    assert plan.skipped == (f"line {_line(text, 'TPWrite')}: TPWrite",)
    # Executed in call order: main's move, then those of Others.
    assert [m.target for m in plan.moves] == [
        "pChosen",
        "pFlipped",
        "pTurned",
        "Offs(pTurned, 0, 0, 50)",
    ]
    for move, conf in zip(plan.moves, [*confs, confs[2]], strict=True):
        assert configuration(kin, move.q) == conf, move.target
    T_written = module.targets["pChosen"].T_wobj_tcp  # T to the 0.1 um of the text
    for move in plan.moves[:3]:
        np.testing.assert_allclose(kin.fk(move.q), T_written, atol=1e-9)
    np.testing.assert_allclose(plan.moves[0].q, q_chosen, atol=1e-6)  # its only solution there
    T_up = T_written.copy()
    T_up[2, 3] += 0.05
    np.testing.assert_allclose(kin.fk(plan.moves[3].q), T_up, atol=1e-9)

    controller, truth = make_cell(CellConfig(seed=0))
    # A controller with the absolute-accuracy option moves another arm: refused, nothing moved.
    controller.set_absolute_accuracy(robot.kinematics(np.full(len(robot.parameters), 1e-3)))
    clock = controller.time_s
    with pytest.raises(ExecutionError, match="other kinematics"):
        execute_plan(controller, plan)
    assert controller.time_s == clock
    controller.set_absolute_accuracy(None)
    q_true: list[np.ndarray] = []
    record = execute_plan(controller, plan, on_move=lambda _what: q_true.append(truth.q()))
    q_true = q_true[1:]  # after the move to the start: the program's moves
    assert len(record.moves) == 4 and record.touches == (record.moves[3],)
    for executed, q_real in zip(record.moves, q_true, strict=True):
        planned = executed.move.q
        # Encoders: the commanded joints within their noise (1e-5 rad, 5 sigma).
        assert np.max(np.abs(executed.q_measured - planned)) < 5e-5
        # The real joints: within the drives' lost motion and sag (well under 1 mrad) of the
        # plan, in the same configuration.
        assert np.max(np.abs(q_real - planned)) < 1e-3
        assert configuration(kin, q_real) == configuration(kin, planned)


# -- bad input: one line, exit 2, nothing moved ----------------------------------------------------
_CONF = re.compile(r"\],\[(-?\d+),(-?\d+),(-?\d+),(-?\d+)\],\[")


def _other_wrist_bit(declaration: str) -> str:
    """A robtarget declaration with cfx bit 0 (axis 5's sign) flipped and axes 4 and 6 kept in
    their quadrants: no solution of a spherical wrist has that configuration."""
    c = [int(v) for v in _CONF.search(declaration).groups()]  # type: ignore[union-attr]
    return _CONF.sub(f"],[{c[0]},{c[1]},{c[2]},{c[3] ^ 1}],[", declaration)


def _cases(module: str) -> dict[str, tuple[str, str, str]]:
    """label -> (module text, a fragment of the line to name, what the message says)."""
    lines = module.splitlines()
    app = next(line for line in lines if "robtarget pKocher_rightApp" in line)
    touch = next(line for line in lines if "robtarget pKocher_rightTouch" in line)
    far = re.sub(  # 3 m up: beyond the arm's reach (1.55 m) wherever it stands
        r":= \[\[([-\d.]+), ?([-\d.]+), ?([-\d.]+)\]",
        lambda m: f":= [[{m[1]},{m[2]},{float(m[3]) + 3000:.4f}]",
        app,
    )
    first_movej = "    MoveJ pKocher_rightApp,"
    return {
        "syntax": (
            module.replace("vTouch, fine", "vTouch fine", 1),
            "MoveL pKocher_rightTouch",
            "missing ';'",
        ),
        "instruction": (
            module.replace(first_movej, "    Sing 3;\n" + first_movej, 1),
            "Sing 3;",
            "unknown instruction 'Sing'",
        ),
        "control flow": (
            module.replace(first_movej, "    WHILE TRUE DO\n    ENDWHILE\n" + first_movej, 1),
            "WHILE TRUE",
            "WHILE in PROC main",
        ),
        "unreachable": (
            module.replace(app, far),
            first_movej,
            "the nominal arm cannot reach the target",
        ),
        "configuration": (
            module.replace(app, _other_wrist_bit(app)),
            first_movej,
            "the nominal arm has no solution in configuration [",
        ),
        "linear configuration": (
            module.replace(touch, _other_wrist_bit(touch)),
            "MoveL pKocher_rightTouch",
            "ConfL",
        ),
        "work object": (
            module.replace("\\WObj:=wobjObject", "\\WObj:=wobjTable", 1),
            first_movej,
            "wobjTable",
        ),
        "tool": (
            module.replace("tScrewer", "tPointer").replace("[[0, 0, 200]", "[[0, 0, 350]"),
            first_movej,
            "no tool of the cell matches tooldata tPointer",
        ),
    }


@pytest.mark.slow
def test_bad_programs_are_refused_naming_the_line_before_any_motion(
    folder: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    built: list[object] = []
    monkeypatch.setattr(
        "scenarios.jobs.execute_run_folder.rebuild_job_cell", lambda *args: built.append(args)
    )
    before = (folder / "execution.json").read_bytes()
    for label, (text, fragment, message) in _cases((folder / "program.mod").read_text()).items():
        path = tmp_path / f"{label.replace(' ', '_')}.mod"
        path.write_text(text)
        capsys.readouterr()
        code = main(["execute", str(folder), "--program", str(path), "--quiet"])
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2, (label, err)
        assert len(err) == 1, (label, err)
        assert err[0].startswith(f"twincell: error: {path}:{_line(text, fragment)}: "), (label, err)
        assert message in err[0], (label, err)
    assert built == []  # no real cell was built: nothing moved
    assert (folder / "execution.json").read_bytes() == before


def test_a_folder_without_its_files_is_refused(
    short_skull_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Any run's files, one left out: the session's short skull job (tests/conftest.py)."""
    folder = short_skull_run
    for missing, kept in (("program.mod", "config.yaml"), ("config.yaml", "program.mod")):
        partial = tmp_path / f"without-{missing}"
        partial.mkdir()
        (partial / kept).write_bytes((folder / kept).read_bytes())
        capsys.readouterr()
        assert main(["execute", str(partial)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith(f"twincell: error: {partial / missing}: ")
        assert "no such file" in err[0]
        assert not (partial / "execution.json").exists()


@pytest.mark.parametrize(
    ("body", "fragment", "message"),
    [
        (
            "    IF TRUE THEN\n      MoveJ p1, v100, fine, tool0;\n    ENDIF",
            "IF TRUE",
            "IF in PROC",
        ),
        ("    FOR i FROM 1 TO 2 DO\n    ENDFOR", "FOR i", "FOR in PROC"),
        ("    TEST 1\n    CASE 1:\n    ENDTEST", "TEST 1", "TEST in PROC"),
        ("    Again;", "PROC Again", "recursion"),
        ("    Twice 2;", "Twice 2;", "passes arguments"),
        ("    MoveC p1, p1, v100, fine, tool0;", "MoveC", "MoveC is not executed"),
        ("    MoveL p1, v100 \\T:=3, fine, tool0;", "\\T:=3", "\\T are not executed"),
        ("    MoveJ p1, vFast, fine, tool0;", "MoveJ p1, vFast", "speed vFast"),
        ("    MoveJ p1, v100, fine \\Inpos:=vFast, tool0;", "Inpos:=vFast", "\\Inpos:=vFast"),
    ],
)
def test_what_the_executor_cannot_follow_is_refused_naming_its_line(
    body: str, fragment: str, message: str
) -> None:
    robot = irb2400()
    kin = robot.kinematics()
    T = kin.fk(np.array([0.1, 0.3, 0.1, 0.4, -0.8, 0.5]))
    text = "\n".join(
        [
            "MODULE Flow",
            _robtarget("p1", T, configuration(kin, np.array([0.1, 0.3, 0.1, 0.4, -0.8, 0.5]))),
            "  CONST num vFast := 3000;",
            "  PROC main()",
            "    MoveJ p1, v100, fine, tool0;",
            "    Again;",
            "  ENDPROC",
            "  PROC Again()",
            body,
            "  ENDPROC",
            "  PROC Twice(num n)",
            "    MoveJ p1, v100, fine, tool0;",
            "  ENDPROC",
            "ENDMODULE",
            "",
        ]
    )
    if "Again;" in body:  # the recursion is the call inside Again
        fragment = "    Again;"
        line = [i for i, s in enumerate(text.splitlines(), 1) if s == fragment][-1]
    else:
        line = _line(text, fragment)
    tools = {t.name: t.T_tool_tcp for t in TOOLS}
    with pytest.raises(RapidError) as raised:
        plan_execution(read_module(text, "flow.mod"), kin, tools, robot.q_home, robot.joint_speed)
    # A module read from a text is named after its MODULE line.
    assert str(raised.value).startswith(f"module Flow:{line}: "), str(raised.value)
    assert message in str(raised.value)
    assert re.search(r"\n", str(raised.value)) is None


@pytest.mark.parametrize(
    ("stop", "declared", "stop_time_s"),
    [
        ("fine", "", None),
        ("fine \\Inpos:=inpos50", "", None),
        ("fine \\Inpos:=stoptime1_0", "", 1.0),
        ("fine \\Inpos:=sStand", '[stoptime, FALSE, [0, 0, 0, 0], 0.25, 0, "", 0, 0]', 0.25),
        ("fine \\Inpos:=sStand", '[inpos, TRUE, [25, 40, 0.1, 5], 0, 0, "", 0, 0]', None),
    ],
)
def test_a_stop_point_stands_its_stoppointdata_s_stoptime(
    stop: str, declared: str, stop_time_s: float | None
) -> None:
    """A stop point's \\Inpos of type stoptime (RAPID's predefined stoptime0_5 .. 1_5, or
    one declared) is the time the arm stands still there; of type inpos, or none, the
    controller settles as at fine (None)."""
    robot = irb2400()
    kin = robot.kinematics()
    q = np.array([0.1, 0.3, 0.1, 0.4, -0.8, 0.5])
    lines = ["MODULE Stand", _robtarget("p1", kin.fk(q), configuration(kin, q))]
    if declared:
        lines.append(f"  CONST stoppointdata sStand := {declared};")
    lines += ["  PROC main()", f"    MoveJ p1, v100, {stop}, tool0;", "  ENDPROC", "ENDMODULE", ""]
    module = read_module("\n".join(lines), "stand.mod")
    plan = plan_execution(module, kin, {}, robot.q_home, robot.joint_speed)
    (move,) = plan.moves
    assert move.stop and move.stop_time_s == stop_time_s

    class Cell:  # what run_move asks of a controller, and the settling it was told
        kinematics = kin
        time_s = 0.0

        def __init__(self) -> None:
            self.settled: list[float] = []

        def table_position(self) -> float:
            return 0.0

        def move_joints(self, q: np.ndarray, speed: float, settle_s: float) -> None:
            self.settled.append(settle_s)

        def read_joints(self) -> np.ndarray:
            return move.q

    cell = Cell()
    run_move(cell, plan, move)  # type: ignore[arg-type]
    assert cell.settled == [SETTLE_S if stop_time_s is None else stop_time_s]


def test_motion_sup_off_runs_the_moves_after_it_unsupervised() -> None:
    """MotionSup \\Off switches the supervision off for the moves after it, \\On back on;
    the executor runs an unsupervised move inside the controller's supervision_off."""
    robot = irb2400()
    kin = robot.kinematics()
    q = np.array([0.1, 0.3, 0.1, 0.4, -0.8, 0.5])
    lines = [
        "MODULE Sup", _robtarget("p1", kin.fk(q), configuration(kin, q)), "  PROC main()",
        "    MoveJ p1, v100, fine, tool0;", "    MotionSup \\Off;",
        "    MoveJ p1, v100, fine, tool0;", "    MotionSup \\On;",
        "    MoveJ p1, v100, fine, tool0;", "  ENDPROC", "ENDMODULE", "",
    ]  # fmt: skip
    plan = plan_execution(
        read_module("\n".join(lines), "sup.mod"), kin, {}, robot.q_home, robot.joint_speed
    )
    assert [m.supervised for m in plan.moves] == [True, False, True]

    class Cell:  # what run_move asks of a controller, and whether it supervised each move
        kinematics = kin
        time_s = 0.0

        def __init__(self) -> None:
            self.watching = True
            self.watched: list[bool] = []

        @contextmanager
        def supervision_off(self) -> Iterator[None]:
            self.watching = False
            yield
            self.watching = True

        def table_position(self) -> float:
            return 0.0

        def move_joints(self, q: np.ndarray, speed: float, settle_s: float) -> None:
            self.watched.append(self.watching)

        def read_joints(self) -> np.ndarray:
            return q

    cell = Cell()
    for move in plan.moves:
        run_move(cell, plan, move)  # type: ignore[arg-type]
    assert cell.watched == [True, False, True]
    bad = "\n".join(lines).replace("MotionSup \\On", "MotionSup \\Fast")
    with pytest.raises(RapidError, match="MotionSup needs"):
        plan_execution(read_module(bad, "sup.mod"), kin, {}, robot.q_home, robot.joint_speed)
