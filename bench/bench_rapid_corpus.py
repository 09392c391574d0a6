"""How many RAPID modules of public controller backups and programs the reader reads, and why
it refuses the others: before (a commit's `read_module`, file by file) and after (this
checkout: each backup task folder read as a task, every other file on its own).

    python bench/bench_rapid_corpus.py FOLDER... [--task NAME=FILE,FILE,...]
                                       [--task-dir DIR] [--before COMMIT]
    python bench/bench_rapid_corpus.py --short     (the tests' own files, tests/data/rapid)

The figures in the README came from these public repositories, fetched (a snapshot of each,
its RAPID files only) into one folder per repository, owner+name:
ros-industrial/abb_driver, robotics/open_abb, tetov/compas_rcf, SDEBEUL/Kraker1,
Keen1949/ABB_ROBOT_Socket, PaulaFreudenberger/ABB-Rapid-Git, joseballester/abb-rapidserver,
EdgarIvanMM/Tamponadora, EdgarIvanMM/PaletizadoCajasConFrascos,
Fabio-Coder/Robo_ABB_Injetora-Rotinas_de_ajuste,
panin-anan/abb_SAMXL_Grinding_RAPID, ravenorb/abb-robot-welder; and run as

    D=folder-of-the-sources; A=$D/ros-industrial+abb_driver/rapid; C=$A/ROS_common.sys
    python bench/bench_rapid_corpus.py $D/* \
      --task T_ROB1=$C,$A/ROS_socket.sys,$A/ROS_messages.sys,$A/ROS_motion.mod \
      --task ROS_StateServer=$C,$A/ROS_socket.sys,$A/ROS_messages.sys,$A/ROS_stateServer.mod \
      --task ROS_MotionServer=$C,$A/ROS_socket.sys,$A/ROS_messages.sys,$A/ROS_motionServer.mod \
      --task-dir $D/ravenorb+abb-robot-welder/sample \
      --task-dir $D/panin-anan+abb_SAMXL_Grinding_RAPID/HOME/Projects/BrightSkyGrinder/Loop_grind

(abb_driver's three tasks as its installation loads them; the welder's sample/ and the
grinder's project folder are folders of one task each).

Each FOLDER is one source (e.g. a fetched repository); it is not downloaded here. Its files
ending in .mod, .modx, .sys or .prg are counted. After: every folder named TASKn below it (a
backup's RAPID/TASKn, with PROGMOD and SYSMOD), the parent of a PROGMOD folder outside one,
and each --task-dir is read as one task (read_task, strict=False: a module that cannot be
read is left out and counted as refused, its reason kept; an encrypted module
of a task is kept unread and counted apart); `--task` names a task of loose
files (e.g. ROS abb_driver's T_ROB1: ROS_common.sys, ROS_socket.sys, ROS_messages.sys,
ROS_motion.mod); every other file is read on its own (read_module). Before: the code of
--before (default: the commit before tasks were added) exported with `git archive` to a
temporary folder and run in a fresh process on the same files ("-" if that commit is not in
this clone). Reasons are grouped with quoted names and numbers blanked.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
from collections import Counter
from pathlib import Path

SUFFIXES = (".mod", ".modx", ".sys", ".prg")
#: What a file of a task kept unread is marked (an encrypted module: read_task's opaque).
UNREAD = "kept unread"
BEFORE = "5c7a0ad"


def module_files(folder: Path) -> list[Path]:
    """The RAPID files below `folder`, sorted."""
    return sorted(p for p in folder.rglob("*") if p.is_file() and p.suffix.lower() in SUFFIXES)


def reason(message: str, path: Path | None = None) -> str:
    """A refusal's reason with the file, the line, names and numbers blanked."""
    text = message.removeprefix("left out: ")
    if path is not None:
        text = text.replace(str(path), "FILE")
    if "is encrypted or binary" in text:
        return "is encrypted or binary, not RAPID text"
    text = re.sub(r"^.*?(, line \d+)?: ", "", text, count=1)  # the file and the line
    text = re.sub(r"'[^']*'", "'X'", text)
    return re.sub(r"\d+", "N", text)[:110]


def read_files(files: list[Path]) -> dict[str, str | None]:
    """file -> None (read) or the error, with `read_module` of whatever code is importable
    (the reader's module today, rapid/module.py in the commits before the package's split)."""
    import importlib

    module = importlib.import_module("scenarios.rapid.module")
    if not hasattr(module, "read_module"):
        module = importlib.import_module("scenarios.rapid.reader")
    errors = (
        module
        if hasattr(module, "RapidError")
        else importlib.import_module("scenarios.rapid.syntax")
    )
    read_module, rapid_error = module.read_module, errors.RapidError

    out: dict[str, str | None] = {}
    for file in files:
        try:
            read_module(file)
            out[str(file)] = None
        except rapid_error as exc:
            out[str(file)] = str(exc)
    return out


def read_after(
    folder: Path, tasks: dict[str, list[Path]], task_dirs: list[Path]
) -> dict[str, str | None]:
    """file -> None (read) or the reason it was refused, with tasks where there are tasks."""
    out: dict[str, str | None] = {}
    groups = [
        d.parent if d.name.upper() == "PROGMOD" else d
        for d in sorted(folder.rglob("*"))
        if d.is_dir()
        and (
            re.fullmatch(r"TASK\d+", d.name)
            or (d.name.upper() == "PROGMOD" and not re.fullmatch(r"TASK\d+", d.parent.name))
        )
    ]
    groups += [d for d in task_dirs if d.is_relative_to(folder)]
    for task_dir in groups:
        files = module_files(task_dir)
        if not files:
            continue
        _read_group(files, out)
    for files in tasks.values():
        mine = [f for f in files if f.is_relative_to(folder)]
        if mine:
            _read_group(mine, out)
    rest = [f for f in module_files(folder) if str(f) not in out]
    out |= read_files(rest)
    return out


def _read_group(files: list[Path], out: dict[str, str | None]) -> None:
    """Read `files` as one task (strict=False); each file -> None or why it was left out."""
    from scenarios.rapid.syntax import RapidError
    from scenarios.rapid.task import read_task

    try:
        task = read_task(files, strict=False)
    except RapidError as exc:  # the task cannot be read at all
        out |= {str(f): str(exc) for f in files}
        return
    read = {str(m.path) for m in task.modules}
    unread = {str(p) for p in task.opaque}
    left = [w for w in task.warnings if w.startswith("left out: ")]
    for f in files:
        why = next((w for w in left if str(f) in w), "left out")
        out[str(f)] = None if str(f) in read else UNREAD if str(f) in unread else why


def before(files: list[Path], commit: str) -> dict[str, str | None] | None:
    """read_files at `commit`, in a fresh process on an exported copy of its code; None if
    the commit is not in this clone (a shallow one)."""
    root = Path(__file__).resolve().parent.parent
    exported = subprocess.run(
        ["git", "-C", str(root), "archive", commit, "scenarios"], capture_output=True
    )
    if exported.returncode != 0:
        return None
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run(["tar", "-x", "-C", tmp], input=exported.stdout, check=True)
        code = (
            "import json, sys; from pathlib import Path; "
            f"sys.path.insert(0, {str(Path(__file__).parent)!r}); "
            "from bench_rapid_corpus import read_files; "
            "print(json.dumps(read_files([Path(p) for p in sys.argv[1:]])))"
        )
        done = subprocess.run(
            [sys.executable, "-c", code, *map(str, files)],
            capture_output=True,
            text=True,
            check=True,
            env={"PYTHONPATH": tmp, "PATH": "/usr/bin:/bin"},
            cwd=tmp,
        )
    result: dict[str, str | None] = json.loads(done.stdout)
    return result


def counts(results: dict[str, str | None] | None) -> tuple[str, str]:
    """(read, refused) as text, a task's encrypted modules kept unread counted in neither;
    "-" where there are no results."""
    if results is None:
        return "-", "-"
    n_read = sum(r is None for r in results.values())
    n_unread = sum(r == UNREAD for r in results.values())
    return str(n_read), str(len(results) - n_read - n_unread)


def unread(results: dict[str, str | None]) -> str:
    """How many files of tasks were kept unread (encrypted), as text."""
    return str(sum(r == UNREAD for r in results.values()))


def reasons(results: dict[str, str | None] | None) -> list[str]:
    """The refusals' reasons, most frequent first, with their counts."""
    if results is None:
        return ["     (the commit is not in this clone)"]
    refused = Counter(
        reason(r, Path(f)) for f, r in results.items() if r is not None and r != UNREAD
    )
    return [f"{n:5d}  {why}" for why, n in refused.most_common()]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folders", nargs="*", type=Path)
    parser.add_argument("--task", action="append", default=[], help="NAME=FILE,FILE,...")
    parser.add_argument(
        "--task-dir",
        action="append",
        default=[],
        type=Path,
        help="a folder of loose modules to read as one task",
    )
    parser.add_argument("--before", default=BEFORE)
    parser.add_argument("--short", action="store_true", help="the tests' own RAPID files only")
    args = parser.parse_args()
    folders, task_dirs = list(args.folders), list(args.task_dir)
    if args.short:
        folders = [Path(__file__).resolve().parent.parent / "tests" / "data" / "rapid"]
        task_dirs = [folders[0] / "abb_driver_t_rob1"]
    if not folders:
        parser.error("give the folders of the fetched sources (or --short)")
    tasks = {
        spec.partition("=")[0]: [Path(f).resolve() for f in spec.partition("=")[2].split(",")]
        for spec in args.task
    }
    header = (
        "source", "files", "read before", "refused before", "read after", "refused after",
        "kept unread after",
    )  # fmt: skip
    print(" | ".join(header))
    details: list[str] = []
    total = Counter[str]()
    for folder in (f.resolve() for f in folders):
        files = module_files(folder)
        old = before(files, args.before)
        new = read_after(folder, tasks, [d.resolve() for d in task_dirs])
        row = (*counts(old), *counts(new), unread(new))
        print(" | ".join((folder.name, str(len(files)), *row)))
        total["files"] += len(files)
        for key, value in zip(header[2:], row, strict=True):
            total[key] += int(value) if value != "-" else 0
        details += [f"{folder.name}, before ({args.before}):", *reasons(old)]
        details += [f"{folder.name}, after:", *reasons(new)]
    if len(folders) > 1:
        print(" | ".join(("all", *(str(total[k]) for k in header[1:]))))
    print("\nreasons of the refusals (names and numbers blanked):")
    print("\n".join(details))


if __name__ == "__main__":
    main()
