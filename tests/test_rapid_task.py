"""RAPID as controllers run it: a task of several modules (names across modules, LOCAL scope),
every instruction parsed whatever its name, the %%% header and module attributes, conditional
optional arguments, encrypted or binary files refused as such, `twincell rapid`, and the
executor running `main` wherever it is.

Ground truth is the modules' own numbers as the tests write them (positions in mm, speeds) and
the line numbers found by scanning the texts, never the reader's output; the fixture
tests/data/rapid/abb_driver_t_rob1 is ROS abb_driver's T_ROB1 task, unchanged (BSD)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from cell.irb2400_arm import irb2400
from models.robot import TOOLS
from scenarios.cli.app import main
from scenarios.rapid.planner import plan_execution
from scenarios.rapid.reader import read_module
from scenarios.rapid.syntax import RapidError
from scenarios.rapid.task import read_task

ABB_DRIVER = Path(__file__).parent / "data" / "rapid" / "abb_driver_t_rob1"
UNUSED = "[9E9,9E9,9E9,9E9,9E9,9E9]"
DOWN = "[0,0,1,0]"  # 180 deg about y: the tool points down

DATA = f"""%%%
  VERSION:1
  LANGUAGE:ENGLISH
%%%

MODULE Data(SYSMODULE, NOSTEPIN)
  ! Work object, a speed and targets shared by the task's modules.
  PERS wobjdata wobjA := [FALSE,TRUE,"",[[600,0,200],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
  CONST speeddata vSlow := [50,30,200,15];
  CONST robtarget pA := [[0,0,300],{DOWN},[0,0,0,0],{UNUSED}];
  LOCAL CONST robtarget pHidden := [[0,50,300],{DOWN},[0,0,0,0],{UNUSED}];
  RECORD point2
    num x;
    num y;
  ENDRECORD
ENDMODULE
"""

MOTION = """MODULE Motion
  VAR point2 corner := [1, 2];
  VAR iodev logfile;
  PROC main()
    ConfJ \\Off;
    ConfL \\Off;
    MoveJ pA, v500, z10, tool0\\WObj:=wobjA;
    Approach;
    Close logfile;
  ENDPROC
  PROC Unused()
    Frobnicate 1;
    Frobnicate 2;
    Helper;
    WaitTestAndSet corner.x;
  ENDPROC
ENDMODULE
"""

MOVES = f"""MODULE Moves
  ! This module's own pA hides the task's global one.
  LOCAL CONST robtarget pA := [[0,0,100],{DOWN},[0,0,0,0],{UNUSED}];
  PROC Approach()
    MoveL pA, vSlow, fine, tool0\\WObj:=wobjA;
    Helper;
  ENDPROC
  LOCAL PROC Helper()
    WaitTime 0.1;
  ENDPROC
ENDMODULE
"""


def _task(folder: Path, **texts: str) -> Path:
    """A folder holding one module file per keyword (name.mod -> text)."""
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in texts.items():
        (folder / f"{name}.mod").write_text(text)
    return folder


def _line(text: str, fragment: str) -> int:
    return next(i for i, line in enumerate(text.splitlines(), 1) if fragment in line)


@pytest.fixture
def three(tmp_path: Path) -> Path:
    return _task(tmp_path / "task", Data=DATA, Motion=MOTION, Moves=MOVES)


# -- a task: names across modules, LOCAL scope ----------------------------------------------------
def test_a_folder_is_one_task_whose_names_resolve_across_modules(three: Path) -> None:
    task = read_task(three)
    assert [m.name for m in task.modules] == ["Data", "Motion", "Moves"]
    data, motion, moves = task.modules
    assert data.header == (("VERSION", "1"), ("LANGUAGE", "ENGLISH"))
    assert data.attributes == ("SYSMODULE", "NOSTEPIN")
    assert data.records == ("point2",)
    # Motion's MoveJ pA is Data's global pA (z 300 mm); Moves' MoveL pA its own LOCAL one
    # (z 100 mm): both in wobjA's object frame, exactly as written.
    (movej,) = motion.moves
    (movel,) = moves.moves
    assert movej.T_wobj_tcp is not None and movel.T_wobj_tcp is not None
    np.testing.assert_allclose(movej.T_wobj_tcp[:3, 3], [0, 0, 0.3], atol=1e-12)
    np.testing.assert_allclose(movel.T_wobj_tcp[:3, 3], [0, 0, 0.1], atol=1e-12)
    np.testing.assert_allclose(movej.T_wobj_tcp[:3, :3], np.diag([-1.0, 1.0, -1.0]), atol=1e-12)
    assert [(r.kind, r.name, r.local) for r in moves.routines] == [
        ("PROC", "Approach", False),
        ("PROC", "Helper", True),
    ]
    # Warnings: once per procedure defined nowhere (Frobnicate, twice called), and Helper
    # is LOCAL to Moves, so Motion's call finds it nowhere; Close and WaitTestAndSet are
    # RAPID instructions.
    assert len(task.warnings) == 2, task.warnings
    frob, helper = task.warnings
    assert frob.startswith(f"{three / 'Motion.mod'}, line {_line(MOTION, 'Frobnicate 1')}: ")
    assert "Frobnicate is called but defined nowhere in the task" in frob
    assert helper.startswith(f"{three / 'Motion.mod'}, line {_line(MOTION, 'Helper;')}: ")


def test_the_executor_runs_main_wherever_it_is_across_modules(three: Path) -> None:
    robot = irb2400()
    tools = {t.name: t.T_tool_tcp for t in TOOLS}
    plan = plan_execution(
        read_task(three), robot.kinematics(), tools, robot.q_home, robot.joint_speed
    )
    assert [(m.instruction, m.routine) for m in plan.moves] == [
        ("MoveJ", "main"),
        ("MoveL", "Approach"),
    ]
    assert plan.source == str(three) and plan.module == "Motion"
    # wobjA's user frame is at [600, 0, 200] mm: the targets at 300 and 100 mm above it.
    np.testing.assert_allclose(plan.moves[0].T_base_tcp[:3, 3], [0.6, 0, 0.5], atol=1e-12)
    np.testing.assert_allclose(plan.moves[1].T_base_tcp[:3, 3], [0.6, 0, 0.3], atol=1e-12)
    assert plan.moves[1].source == str(three / "Moves.mod")
    assert plan.moves[1].v_tcp_m_s == pytest.approx(0.050, abs=1e-12)  # Data's vSlow
    # The joints the plan reaches put the flange where the targets are (FK, 1 micron).
    for move in plan.moves:
        np.testing.assert_allclose(
            robot.kinematics().fk(move.q)[:3, 3], move.T_base_tcp[:3, 3], atol=1e-6
        )
    # Helper's WaitTime and main's Close are RAPID instructions that do not move the arm.
    assert [s.split(": ")[1] for s in plan.skipped] == ["WaitTime", "Close"]


def test_local_data_and_routines_stay_in_their_module(three: Path) -> None:
    hidden = MOTION.replace("MoveJ pA,", "MoveJ pHidden,")
    (three / "Motion.mod").write_text(hidden)
    with pytest.raises(RapidError) as raised:
        read_task(three)
    message = str(raised.value)
    assert message.startswith(f"{three / 'Motion.mod'}, line {_line(hidden, 'pHidden')}: ")
    assert "the target pHidden of MoveJ is not declared" in message
    # Without strict, the module is left out and named; the others are read.
    loose = read_task(three, strict=False)
    assert [m.name for m in loose.modules] == ["Data", "Moves"]
    assert loose.warnings[0].startswith(f"left out: {three / 'Motion.mod'}, line ")


def test_a_name_declared_twice_in_a_task_is_refused(three: Path) -> None:
    twice = MOVES.replace("  LOCAL PROC Helper", "  PROC main()\n  ENDPROC\n  LOCAL PROC Helper")
    (three / "Moves.mod").write_text(twice)
    with pytest.raises(RapidError) as raised:
        read_task(three)
    message = str(raised.value)
    assert message.startswith(f"{three / 'Moves.mod'}, line ")
    assert (
        f"PROC main is declared in two modules of the task (also {three / 'Motion.mod'}" in message
    )


def test_folders_of_a_backup(tmp_path: Path) -> None:
    backup = tmp_path / "backup"
    _task(backup / "RAPID" / "TASK1" / "PROGMOD", Motion=MOTION, Moves=MOVES)
    sysmod = backup / "RAPID" / "TASK1" / "SYSMOD"
    sysmod.mkdir()
    (sysmod / "Data.sys").write_text(DATA)
    (backup / "RAPID" / "TASK1" / "notes.txt").write_text("not RAPID")
    # The backup's one task: PROGMOD's and SYSMOD's modules together.
    assert sorted(m.name for m in read_task(backup).modules) == ["Data", "Motion", "Moves"]
    _task(backup / "RAPID" / "TASK2" / "PROGMOD", Other="MODULE Other\nENDMODULE\n")
    with pytest.raises(RapidError, match=r"holds 2 tasks .*TASK1.*TASK2.*give one of them"):
        read_task(backup)
    assert len(read_task(backup / "RAPID" / "TASK2").modules) == 1
    (tmp_path / "empty").mkdir()
    with pytest.raises(RapidError, match=r"empty holds no RAPID module"):
        read_task(tmp_path / "empty")
    with pytest.raises(RapidError, match="no such file or folder"):
        read_task(tmp_path / "missing")


# -- the grammar, whatever the instruction's name -------------------------------------------------
SYNTAX = """%%%
  VERSION:1
  LANGUAGE:ENGLISH
%%%
MODULE Syntax(SYSMODULE, NOSTEPIN, VIEWONLY, READONLY, NOVIEW)
  ALIAS num distance;
  LOCAL RECORD pair
    num a;
    distance b;
  ENDRECORD
  VAR intnum tick;
  VAR pair p := [1, 2];
  PROC r_Move(
    jointtarget ExpectJoint
    \\switch FlyBy
    \\num Speed)
    r_Inner ExpectJoint\\FlyBy?FlyBy \\Speed ? Speed;
    IF Present(FlyBy) TPWrite "fly by";
  ERROR
    RETRY;
  UNDO
    TPWrite "undo";
  ENDPROC
  PROC r_Inner(jointtarget J \\switch FlyBy \\num Speed)
    %"r_" + "Late"% J;
    CONNECT tick WITH onTick;
    ITimer 1, tick;
    SocketCreate socket1;
    WaitTestAndSet lock1;
    Close logfile;
    TEST p.a
    CASE 1, 2:
      Incr p.a;
    DEFAULT:
      p.b := Abs(p.b \\Sign?FlyBy);
    ENDTEST
  BACKWARD
    TPWrite "back";
  ENDPROC
  LOCAL FUNC num twice(num x)
    RETURN 2 * x;
  ERROR
    RETURN 0;
  ENDFUNC
  TRAP onTick
    TPWrite "tick";
  ENDTRAP
ENDMODULE
"""


def test_every_statement_the_grammar_allows_is_read() -> None:
    module = read_module(SYNTAX, "syntax.mod")
    assert module.header == (("VERSION", "1"), ("LANGUAGE", "ENGLISH"))
    assert module.attributes == ("SYSMODULE", "NOSTEPIN", "VIEWONLY", "READONLY", "NOVIEW")
    assert module.records == ("distance", "pair")
    assert [(r.kind, r.name, r.local) for r in module.routines] == [
        ("PROC", "r_Move", False),
        ("PROC", "r_Inner", False),
        ("FUNC", "twice", True),
        ("TRAP", "onTick", False),
    ]
    # Parameters on their own lines, the optional ones without a comma before the '\'.
    assert module.routines[0].parameters == {"expectjoint", "flyby", "speed"}
    names = [i.name for i in module.instructions]
    for name in ("r_Inner", "SocketCreate", "WaitTestAndSet", "Close", "ITimer", "Incr"):
        assert name in names, names
    # The only procedure defined nowhere is the late-bound one, which no reader can name.
    assert read_task([_write(SYNTAX)]).warnings == ()


def _write(text: str, name: str = "m.mod") -> Path:
    import tempfile

    folder = Path(tempfile.mkdtemp())
    (folder / name).write_text(text)
    return folder / name


@pytest.mark.parametrize(
    ("old", "new", "fragment", "words"),
    [
        (
            "  ENDPROC\n  PROC r_Inner",
            "  PROC r_Inner",
            "PROC r_Inner",
            ["PROC r_Move", "no ENDPROC"],
        ),
        ("CASE 1, 2:", "CASE 1, 2", "Incr p.a", ["expected ':'"]),
        ("VAR pair p", "VAR pair 2p", "VAR pair 2p", ["'2p' starts with a digit"]),
        (
            "NOVIEW)",
            "NOVIEW, FAST)",
            "MODULE Syntax",
            ["FAST", "is not a module attribute", "VIEWONLY"],
        ),
        (
            "ENDMODULE\n",
            "ENDMODULE\nMoveJ p, v10, fine, tool0;\n",
            "ENDMODULE",
            ["text after ENDMODULE"],
        ),
    ],
    ids=["unbalanced-blocks", "syntax", "digit", "attribute", "after-endmodule"],
)
def test_a_broken_module_is_refused_naming_file_and_line(
    old: str, new: str, fragment: str, words: list[str]
) -> None:
    assert old in SYNTAX
    text = SYNTAX.replace(old, new, 1)
    with pytest.raises(RapidError) as raised:
        read_module(text, "syntax.mod")
    message = str(raised.value)
    assert message.startswith("syntax.mod, line "), message
    line = int(message.split("line ")[1].split(":")[0])
    assert fragment in text.splitlines()[line - 1], (line, message)
    for word in words:
        assert word in message, message
    assert "\n" not in message


def test_placeholders_are_read_and_stop_the_program_where_reached(three: Path) -> None:
    """RAPID's placeholders (<SMT>, <EXP>, <DDN>: what the program editor has not written
    yet) load on a controller, which stops with an error where the program reaches one."""
    unfinished = (
        MOTION.replace("  VAR iodev logfile;", "  VAR iodev logfile;\n  <DDN>")
        .replace("    Frobnicate 2;", "    IF <EXP> THEN\n      <SMT>\n    ENDIF")
        .replace("    Close logfile;", "    Close logfile;\n    <SMT>")
    )
    (three / "Motion.mod").write_text(unfinished)
    task = read_task(three)
    motion = task.modules[1]
    lines = [i for i, line in enumerate(unfinished.splitlines(), 1) if "<" in line]
    assert [line for _name, line in motion.placeholders] == lines
    assert [name for name, _line in motion.placeholders] == ["<DDN>", "<SMT>", "<EXP>", "<SMT>"]
    assert task.warnings[0].startswith(f"{three / 'Motion.mod'}, line {lines[0]}: 4 placeholder")
    robot = irb2400()
    tools = {t.name: t.T_tool_tcp for t in TOOLS}
    with pytest.raises(RapidError) as raised:
        plan_execution(task, robot.kinematics(), tools, robot.q_home, robot.joint_speed)
    # main's <SMT>, after Close (the text's second placeholder).
    assert str(raised.value).startswith(f"{three / 'Motion.mod'}:{lines[1]}: the placeholder")
    # Where the program does not reach them (Unused), they stop nothing.
    (three / "Motion.mod").write_text(unfinished.replace("    Close logfile;\n    <SMT>", ""))
    plan_execution(read_task(three), robot.kinematics(), tools, robot.q_home, robot.joint_speed)


# -- encrypted or binary --------------------------------------------------------------------------
def _encrypted(path: Path) -> Path:
    # The first bytes of a controller's encrypted module are not text (a public backup's
    # begin fc d8 1d e6 07 01); random bytes after them, as encryption leaves them.
    rng = np.random.default_rng(0)
    path.write_bytes(bytes([0xFC, 0xD8, 0x1D, 0xE6, 0x07, 0x01]) + rng.bytes(3000))
    return path


def test_an_encrypted_module_alone_is_refused_as_such(tmp_path: Path) -> None:
    secret = _encrypted(tmp_path / "Secret.mod")
    with pytest.raises(RapidError) as raised:
        read_module(secret)
    assert str(raised.value).startswith(f"{secret} is encrypted or binary, not RAPID text")
    assert "unexpected" not in str(raised.value)
    # A text module with Latin-1 letters in its comments is text.
    umlaut = tmp_path / "Zurich.mod"
    umlaut.write_bytes("MODULE Zurich\n  ! ETH Z\xfcrich, Stra\xdfe\nENDMODULE\n".encode("latin-1"))
    assert read_module(umlaut).name == "Zurich"
    # A task of encrypted modules only has nothing to read.
    with pytest.raises(RapidError, match="every module of the task is encrypted or binary"):
        read_task([secret, _encrypted(tmp_path / "Other.sys")])


def test_an_encrypted_module_in_a_task_is_kept_unread(three: Path) -> None:
    """As a controller loads a task with an encrypted module (a licensed system module, say),
    the task reads with it opaque: named, its symbols unknown; what needs none of them reads
    and plans, and a move that needs one is refused at its line, naming the module."""
    secret = _encrypted(three / "Secret.sys")
    robot = irb2400()
    tools = {t.name: t.T_tool_tcp for t in TOOLS}

    def plan(task_folder: Path) -> None:
        task = read_task(task_folder)
        plan_execution(task, robot.kinematics(), tools, robot.q_home, robot.joint_speed)

    task = read_task(three)
    assert task.opaque == (secret,)
    assert [m.name for m in task.modules] == ["Data", "Motion", "Moves"]
    assert f"{secret}: encrypted or binary: kept in the task unread" in task.warnings[0]
    plan(three)  # the program needs nothing of it
    # A move on a tool declared nowhere readable (in the encrypted module, say): read, and
    # refused where the program reaches it, at its line.
    move = "    MoveL pA, v100, fine, tSecret\\WObj:=wobjA;"
    (three / "Motion.mod").write_text(MOTION.replace("    Approach;", f"{move}\n    Approach;"))
    line = next(i for i, t in enumerate((three / "Motion.mod").read_text().splitlines(), 1)
                if "tSecret" in t)  # fmt: skip
    with pytest.raises(RapidError) as raised:
        plan(three)
    assert str(raised.value) == (
        f"{three / 'Motion.mod'}:{line}: tooldata tSecret is declared in none of the task's "
        "readable modules; its encrypted module(s) Secret.sys may declare it, which only a "
        "controller can read"
    )
    # Where the program does not reach it (Unused), it stops nothing.
    (three / "Motion.mod").write_text(MOTION.replace("    Frobnicate 1;", move))
    plan(three)
    # A call of a routine defined nowhere readable: refused where reached, not on reading.
    (three / "Motion.mod").write_text(
        MOTION.replace("    Approach;", "    rLicensed;\n    Approach;")
    )
    with pytest.raises(
        RapidError,
        match=r"'rLicensed': neither a PROC of the task's readable "
        r"modules nor a RAPID instruction \(the encrypted module\(s\) Secret\.sys",
    ):
        plan(three)
    # Without the encrypted module, such a move is refused when the task is read, as before.
    (three / "Motion.mod").write_text(MOTION.replace("    Frobnicate 1;", move))
    secret.unlink()
    with pytest.raises(RapidError, match="the tool tSecret of MoveL is not declared"):
        read_task(three)


# -- motion the executor does not model -----------------------------------------------------------
@pytest.mark.parametrize(
    ("instruction", "message"),
    [
        (
            "SearchL \\Stop, diSensor, pFound, pA, v100, tool0\\WObj:=wobjA;",
            "SearchL is not executed",
        ),
        ("TriggL pA, v100, trigg1, z10, tool0\\WObj:=wobjA;", "TriggL is not executed"),
        ("MoveExtJ jPos, vrot10, fine;", "MoveExtJ is not executed"),
        ('MoveCSync pA, pA, v100, z10, tool0, "proc"\\WObj:=wobjA;', "MoveCSync is not executed"),
        ("Sing 3;", "unknown instruction 'Sing'"),
    ],
    ids=["search", "trigg", "moveextj", "movecsync", "undefined"],
)
def test_motion_the_executor_cannot_honour_is_refused_naming_it_and_its_line(
    three: Path, instruction: str, message: str
) -> None:
    text = MOTION.replace("    Approach;", f"    {instruction}\n    Approach;")
    (three / "Motion.mod").write_text(text)
    task = read_task(three)  # read: the reader keeps what it does not run
    robot = irb2400()
    tools = {t.name: t.T_tool_tcp for t in TOOLS}
    with pytest.raises(RapidError) as raised:
        plan_execution(task, robot.kinematics(), tools, robot.q_home, robot.joint_speed)
    line = _line(text, instruction.split()[0] + " ")
    assert str(raised.value).startswith(f"{three / 'Motion.mod'}:{line}: "), str(raised.value)
    assert message in str(raised.value)


# -- twincell rapid -------------------------------------------------------------------------------
def test_twincell_rapid_prints_the_task(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["rapid", str(ABB_DRIVER)]) == 0
    out = capsys.readouterr().out
    motion = (ABB_DRIVER / "ROS_motion.mod").read_text()
    assert f"task {ABB_DRIVER}: 3 modules" in out
    assert "MODULE ROS_common (SYSMODULE)" in out
    assert "records and aliases: ROS_joint_trajectory_pt" in out
    assert (
        "PROC main, LOCAL PROC init_trajectory" in out
        and "LOCAL TRAP new_trajectory_handler" in out
    )
    assert "moves (1): main 1" in out
    for name in ("StopMove", "ClearPath", "StartMove"):
        line = _line(motion, f"{name};")
        assert f"ROS_motion.mod, line {line}: {name} in clear_path" in out
    assert "warnings" not in out.split("\n", 1)[1]  # none beyond the count in the first line


def test_twincell_rapid_names_file_and_line_when_unreadable(
    three: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    broken = MOVES.replace("  ENDPROC\n  LOCAL PROC Helper", "  LOCAL PROC Helper")
    (three / "Moves.mod").write_text(broken)
    assert main(["rapid", str(three)]) == 2
    captured = capsys.readouterr()
    err = captured.err.strip().splitlines()
    assert len(err) == 1 and captured.out == ""
    assert err[0].startswith(f"twincell: error: {three / 'Moves.mod'}, line ")
    assert "no ENDPROC" in err[0]
    # Several files of one task, given one by one, read as the folder is.
    files = [str(three / n) for n in ("Data.mod", "Motion.mod")]
    assert main(["rapid", *files]) == 0
    assert "Approach is called but defined nowhere" in capsys.readouterr().out


def test_twincell_rapid_as_a_user_runs_it(tmp_path: Path) -> None:
    """The console script in a fresh process (this checkout's code first on the path): exit 0
    and the summary on stdout; an encrypted module beside it kept unread and said; exit 2 and
    one line on stderr for an encrypted module alone."""
    twincell = Path(sys.executable).with_name("twincell")
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parent.parent)}
    done = subprocess.run(
        [str(twincell), "rapid", str(ABB_DRIVER)], capture_output=True, text=True, env=env
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith(f"task {ABB_DRIVER}: 3 modules, 10 routines, 1 moves")
    secret = tmp_path / "Secret.sys"
    secret.write_bytes(bytes(range(256)))
    done = subprocess.run(
        [str(twincell), "rapid", str(ABB_DRIVER / "ROS_common.sys"), str(secret)],
        capture_output=True,
        text=True,
        env=env,
    )
    assert done.returncode == 0, done.stderr
    assert "1 modules (and 1 encrypted, kept unread)" in done.stdout.splitlines()[0]
    assert f"encrypted module: {secret}" in done.stdout
    assert f"{secret}: encrypted or binary: kept in the task unread" in done.stdout
    done = subprocess.run([str(twincell), "rapid", str(secret)], capture_output=True, text=True,
                          env=env)  # fmt: skip
    assert done.returncode == 2 and done.stdout == ""
    assert (
        done.stderr == f"twincell: error: {secret} is encrypted or binary, not RAPID text "
        "(an encrypted module can only be loaded by a controller)\n"
    )
