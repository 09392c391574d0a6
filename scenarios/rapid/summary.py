"""What the reader made of a RAPID task, as lines of text (`twincell rapid`): per module its
file, attributes and header, routines, tools, work objects, robtargets and moves per routine;
then the motion instructions the executor refuses, and the task's warnings."""

from __future__ import annotations

from collections import Counter

from scenarios.rapid.module import RapidModule
from scenarios.rapid.task import RapidTask


def _names(names: list[str]) -> str:
    return ", ".join(names) if names else "none"


def _module_lines(module: RapidModule) -> list[str]:
    attributes = f" ({', '.join(module.attributes)})" if module.attributes else ""
    header = " ".join(f"{key}:{value}" for key, value in module.header)
    lines = [
        f"MODULE {module.name}{attributes}: {module.label}" + (f" [{header}]" if header else "")
    ]
    routines = [f"{'LOCAL ' if r.local else ''}{r.kind} {r.name}" for r in module.routines]
    lines.append(f"  routines ({len(routines)}): {_names(routines)}")
    if module.records:
        lines.append(f"  records and aliases: {_names(list(module.records))}")
    lines.append(f"  tools: {_names(list(module.tools))}")
    lines.append(f"  work objects: {_names(list(module.wobjs))}")
    lines.append(f"  robtargets: {len(module.targets)}")
    per_routine = Counter(m.routine for m in module.moves)
    moves = [f"{routine} {n}" for routine, n in per_routine.items()]
    lines.append(f"  moves ({len(module.moves)}): {_names(moves)}")
    return lines


def task_lines(task: RapidTask) -> list[str]:
    """The summary of `task` (see the module's docstring), one line per item."""
    n_routines = sum(len(m.routines) for m in task.modules)
    n_moves = sum(len(m.moves) for m in task.modules)
    opaque = f" (and {len(task.opaque)} encrypted, kept unread)" if task.opaque else ""
    lines = [
        f"task {task.label}: {len(task.modules)} modules{opaque}, {n_routines} routines, "
        f"{n_moves} moves, {len(task.warnings)} warnings"
    ]
    for module in task.modules:
        lines += _module_lines(module)
    lines += [f"encrypted module: {path}" for path in task.opaque]
    refused = task.unmodelled_motion()
    if refused:
        lines.append(f"motion the executor refuses ({len(refused)}):")
        lines += [f"  {m.label}, line {i.line}: {i.name} in {i.routine}" for m, i in refused]
    if task.warnings:
        lines.append(f"warnings ({len(task.warnings)}):")
        lines += [f"  {w}" for w in task.warnings]
    return lines
