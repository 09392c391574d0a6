"""A RAPID task as a controller runs it: a set of modules (the program modules of a backup's
`RAPID/TASKn/PROGMOD` and its system modules in `SYSMOD`, or any files given together).

Names resolve across the modules of the task: a routine, a datum or a RECORD type declared in
one module is visible in every other, unless it is LOCAL, in which case only its own module
sees it (and there it hides a global of the same name). Two global declarations of one name,
or two modules of one name, are refused, as a controller refuses to load them.

An instruction is read whatever its name; once the task's routines are known, a call of a
procedure that no module defines and that is not a RAPID instruction
(scenarios.rapid.instructions) is named once in the task's warnings, and so is each module
that holds placeholders (<SMT>, <EXP>, ...: the program editor's marks of what is not written
yet, which a controller loads). Motion instructions the
executor does not model (SearchL, TriggL, MoveExtJ, ...) are read and listed
(`RapidTask.unmodelled_motion`); the executor refuses them where the program reaches them.

An encrypted module of a task (a controller's licensed system module, say) is kept in it
unread, as a controller loads it: named in `RapidTask.opaque` and the warnings, its routines
and data unknown. The other modules read and run; a move that needs a name declared in none of
the readable modules is refused where the program reaches it, naming the encrypted modules
that may declare it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from scenarios.rapid.instructions import is_instruction, is_motion
from scenarios.rapid.module import (
    Declaration,
    Instruction,
    RapidModule,
    RobTarget,
    ToolData,
    WobjData,
)
from scenarios.rapid.parser import parse_module
from scenarios.rapid.reader import build_module
from scenarios.rapid.syntax import Decl, EncryptedModuleError, ModuleText, RapidError, Routine

#: The file name endings of RAPID modules (compared case-insensitively).
RAPID_SUFFIXES = (".mod", ".modx", ".sys", ".prg")
#: The sub-folders of a backup's task folder that hold its modules.
TASK_FOLDERS = ("PROGMOD", "SYSMOD")
#: What the warnings say of an encrypted module kept in its task.
ENCRYPTED_KEPT = (
    "encrypted or binary: kept in the task unread, as a controller loads it; its routines "
    "and data are unknown here (a move that needs one is refused where the program reaches it)"
)
#: What the warnings say of a procedure called and defined nowhere the task can be read.
UNDEFINED_CALL = "is called but defined nowhere"
#: The instructions the executor runs as moves; other motion instructions it refuses.
EXECUTED_MOVES = frozenset({"movej", "movel", "moveabsj"})


@dataclass(frozen=True, eq=False)
class ModuleScope:
    """What a statement of `module` sees of its task: the module's own data (LOCAL ones
    included) over the other modules' global data, by name as declared; `path`, `name`,
    `text` and `label` are the module's."""

    module: RapidModule
    data: dict[str, Declaration]
    tools: dict[str, ToolData]
    wobjs: dict[str, WobjData]
    targets: dict[str, RobTarget]
    opaque: tuple[Path, ...] = ()

    @property
    def path(self) -> Path | None:
        return self.module.path

    @property
    def name(self) -> str:
        return self.module.name

    @property
    def text(self) -> str:
        return self.module.text

    @property
    def label(self) -> str:
        return self.module.label

    def undeclared(self, what: str) -> str:
        """That `what` (e.g. "tooldata tGrip") is declared nowhere the task can be read, with
        the encrypted modules that may declare it."""
        if not self.opaque:
            return f"{what} is not declared in the task"
        return (
            f"{what} is declared in none of the task's readable modules; its encrypted "
            f"module(s) {self.opaque_names} may declare it, which only a controller can read"
        )

    @property
    def opaque_names(self) -> str:
        """The task's encrypted modules' file names, for messages ("" if none)."""
        return ", ".join(p.name for p in self.opaque)


@dataclass(frozen=True, eq=False)
class RapidTask:
    """A task's modules in the order they were given (a folder's files sorted by name), the
    warnings of reading it (procedures defined nowhere; encrypted modules kept unread; with
    `strict=False`, the modules left out and why), the folder it was read from (None for
    files or a single module), and its encrypted modules' files (`opaque`)."""

    modules: tuple[RapidModule, ...]
    warnings: tuple[str, ...] = ()
    path: Path | None = None
    opaque: tuple[Path, ...] = ()

    @property
    def label(self) -> str:
        """What messages call the task: its folder, else its first module's label (and how
        many more modules it has)."""
        if self.path is not None:
            return str(self.path)
        if len(self.modules) > 1:
            return f"{self.modules[0].label} and {len(self.modules) - 1} more modules"
        return self.modules[0].label if self.modules else "an empty task"

    def procedure(self, name: str, caller: RapidModule | None = None) -> RapidModule | None:
        """The module whose PROC `name` a statement of `caller` calls: the caller's own
        PROCs (LOCAL ones included) first, then the other modules' global PROCs; None if
        there is none."""
        key = name.casefold()
        if caller is not None and any(
            r.kind == "PROC" and r.name.casefold() == key for r in caller.routines
        ):
            return caller
        for module in self.modules:
            if module is caller:
                continue
            if any(
                r.kind == "PROC" and not r.local and r.name.casefold() == key
                for r in module.routines
            ):
                return module
        return None

    def scope(self, module: RapidModule) -> ModuleScope:
        """The data a statement of `module` sees (see ModuleScope)."""
        data: dict[str, Declaration] = {}
        tools: dict[str, ToolData] = {}
        wobjs: dict[str, WobjData] = {}
        targets: dict[str, RobTarget] = {}
        for other in (*(m for m in self.modules if m is not module), module):
            mine = other is module
            visible = {n for n, d in other.data.items() if mine or d.scope != "LOCAL"}
            data |= {n: d for n, d in other.data.items() if n in visible}
            tools |= {n: t for n, t in other.tools.items() if n in visible}
            wobjs |= {n: w for n, w in other.wobjs.items() if n in visible}
            targets |= {n: t for n, t in other.targets.items() if n in visible}
        return ModuleScope(module, data, tools, wobjs, targets, self.opaque)

    def routines(self) -> tuple[tuple[RapidModule, Routine], ...]:
        """Every routine of the task with its module."""
        return tuple((m, r) for m in self.modules for r in m.routines)

    def unmodelled_motion(self) -> tuple[tuple[RapidModule, Instruction], ...]:
        """The motion instructions that the executor refuses (every one but MoveJ, MoveL
        and MoveAbsJ), with their modules, in the order of the modules' texts."""
        return tuple(
            (m, i)
            for m in self.modules
            for i in m.instructions
            if i.name.casefold() not in EXECUTED_MOVES
            and is_motion(i.name)
            and self.procedure(i.name, m) is None
        )


def task_of(module: RapidModule) -> RapidTask:
    """A task of one module (its warnings: its placeholders, the procedures it calls and does
    not define)."""
    alone = RapidTask((module,))
    return RapidTask((module,), (*_placeholders(alone), *_undefined(alone)))


def task_files(paths: Iterable[str | Path]) -> list[Path]:
    """The module files of `paths`: a file as given; a folder's RAPID files (RAPID_SUFFIXES)
    and those of its PROGMOD and SYSMOD sub-folders, sorted by name; a backup (a folder with
    RAPID/TASKn or TASKn folders) only if it holds one task. Raises RapidError for a path
    that does not exist, a folder with no RAPID file, or a backup of several tasks."""
    files: list[Path] = []
    for given in paths:
        path = Path(given)
        if path.is_file():
            files.append(path)
        elif path.is_dir():
            files.extend(_folder_files(path))
        else:
            raise RapidError(f"{path}: no such file or folder")
    if not files:
        raise RapidError("no RAPID module given")
    return files


def _folder_files(folder: Path) -> list[Path]:
    root = folder / "RAPID" if (folder / "RAPID").is_dir() else folder
    tasks = sorted(p for p in root.iterdir() if p.is_dir() and p.name.upper().startswith("TASK"))
    if len(tasks) > 1:
        names = ", ".join(str(t) for t in tasks)
        raise RapidError(f"{folder} holds {len(tasks)} tasks ({names}); give one of them")
    if tasks:
        folder = tasks[0]
    found: list[Path] = []
    for sub in (folder, *(p for p in sorted(folder.iterdir()) if p.is_dir())):
        if sub is not folder and sub.name.upper() not in TASK_FOLDERS:
            continue
        found.extend(
            sorted(
                (p for p in sub.iterdir() if p.is_file() and p.suffix.lower() in RAPID_SUFFIXES),
                key=lambda p: p.name.casefold(),
            )
        )
    if not found:
        raise RapidError(
            f"{folder} holds no RAPID module ({', '.join(RAPID_SUFFIXES)} files, directly or "
            f"in {' or '.join(TASK_FOLDERS)})"
        )
    return found


def read_task(paths: Sequence[str | Path] | str | Path, strict: bool = True) -> RapidTask:
    """Read a task: a folder (see task_files) or several module files, as one set of
    modules whose names resolve across them (see the module's docstring). An encrypted module
    among several is kept unread (`RapidTask.opaque`; see the module's docstring). Raises
    RapidError naming the file and line of the first module that cannot be read (a syntax
    error, a name declared in two modules, a move whose data are declared nowhere in the
    task), and for a task whose modules are all encrypted. With `strict=False`, such a module
    is left out and named in the warnings instead, and the task holds the others."""
    given = [paths] if isinstance(paths, str | Path) else list(paths)
    files = task_files(given)
    folder = Path(given[0]) if len(given) == 1 and Path(given[0]).is_dir() else None
    warnings: list[str] = []
    opaque: list[Path] = []

    def refuse(error: RapidError) -> None:
        if strict:
            raise error
        warnings.append(f"left out: {error}")

    texts: list[ModuleText] = []
    for file in files:
        try:
            texts.append(parse_module(file))
        except EncryptedModuleError:
            if len(files) == 1:
                raise
            opaque.append(file)
            warnings.append(f"{file}: {ENCRYPTED_KEPT}")
        except RapidError as exc:
            refuse(exc)
    if opaque and len(opaque) == len(files):
        names = ", ".join(str(p) for p in opaque)
        raise RapidError(f"every module of the task is encrypted or binary: {names}")
    texts = _unique(texts, refuse)
    modules: list[RapidModule] = []
    for text in texts:
        outer: dict[str, Decl] = {}
        for other in texts:
            if other is not text:
                outer |= other.global_data()
        try:
            modules.append(build_module(text, outer, opaque=bool(opaque)))
        except RapidError as exc:
            refuse(exc)
    task = RapidTask(tuple(modules), (), folder, tuple(opaque))
    found = (*warnings, *_placeholders(task), *_undefined(task))
    return RapidTask(task.modules, found, folder, task.opaque)


def _unique(texts: list[ModuleText], refuse: Callable[[RapidError], None]) -> list[ModuleText]:
    """The modules with no module name, global routine or global datum declared twice in
    the task; a module that repeats one is refused (`refuse(error)`)."""
    seen: dict[str, tuple[ModuleText, int]] = {}
    kept: list[ModuleText] = []
    for text in texts:
        names = [(f"MODULE {text.name}", 1)]
        names += [(f"{r.kind} {r.name}", r.line) for r in text.parsed.routines if not r.local]
        names += [(f"data {d.name}", d.line) for d in text.global_data().values()]
        clash = next(((n, line) for n, line in names if n.casefold() in seen), None)
        if clash is None:
            seen |= {n.casefold(): (text, line) for n, line in names}
            kept.append(text)
            continue
        first, first_line = seen[clash[0].casefold()]
        refuse(
            RapidError(
                f"{text.label}, line {clash[1]}: {clash[0]} is declared in two modules of "
                f"the task (also {first.label}, line {first_line}); a controller loads "
                "neither twice (make one LOCAL, or rename it)"
            )
        )
    return kept


def _undefined(task: RapidTask) -> list[str]:
    """One warning per procedure called but defined nowhere in the task and not a RAPID
    instruction, at its first call."""
    warned: set[str] = set()
    warnings: list[str] = []
    for module in task.modules:
        for call in module.instructions:
            key = call.name.casefold()
            if key in warned or is_instruction(call.name) or key.startswith("<"):
                continue
            if task.procedure(call.name, module) is not None:
                continue
            warned.add(key)
            where = "in the task's readable modules" if task.opaque else "in the task"
            warnings.append(
                f"{module.label}, line {call.line}: {call.name} {UNDEFINED_CALL} {where} "
                "(neither a PROC of its modules nor a RAPID instruction)"
            )
    return warnings


def _placeholders(task: RapidTask) -> list[str]:
    """One warning per module holding placeholders (<SMT>, <EXP>, ...), at the first."""
    warnings = []
    for module in task.modules:
        if module.placeholders:
            names = sorted({name for name, _line in module.placeholders})
            warnings.append(
                f"{module.label}, line {module.placeholders[0][1]}: "
                f"{len(module.placeholders)} placeholder(s) {', '.join(names)}: the module is "
                "unfinished (a controller loads it, and stops with an error where the program "
                "reaches one)"
            )
    return warnings
