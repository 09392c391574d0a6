"""The cell's commissioning at the TCP check station: each pointed tool, seated by hand and
known good, read at the beam a few times.

What the arm's own error adds to a reading at the beam is the same whenever the same cell
crosses the beam the same way; these readings are the reference that every later check
differences against (scenarios.offline.tcp_check), and their scatter is the check's
uncertainty on this cell (at least the arm's data-sheet repeatability, which also covers the
tool changer's seat, a few micrometres). A real cell is commissioned once, after
installation or a crash; the simulated cell of a job is commissioned by its runner on a copy
of itself without the faults that the job will meet (scenarios.jobs.pipeline).
"""

from __future__ import annotations

from cell import Controller
from scenarios.offline.tcp_check import POINTERS, read_beam
from scenarios.program.tool_change import change_tool_safely
from scenarios.results.beam import BeamReading, Commissioning

#: The commissioning record's file in a run folder.
COMMISSIONING_FILE = "commissioning.json"
#: Readings per tool: the scatter of two (two degrees of freedom), with the data sheet's
#: repeatability as its floor.
READINGS = 2
#: Each sweep's travel before and after the beam [m]: a tool seated by hand is within a
#: millimetre of its tooldata (a check's sweeps start farther out, for a tool seated off).
SWEEP_M = 0.005


def cell_label(robot: str, seed: int) -> str:
    """The cell as its records name it (the commissioning, a saved calibration): its arm and
    the seed that drew it, "irb2400, seed 5"."""
    return f"{robot}, seed {seed}"


def commission(
    controller: Controller, tools: tuple[str, ...], cell: str, readings: int = READINGS
) -> Commissioning:
    """Take each of `tools` that has a pointer (POINTERS) and read it `readings` times at the
    beam; the arm ends at home with no tool in hand. `cell` names the cell the record is
    of."""
    if readings < 1:
        raise ValueError(f"commissioning takes at least one reading per tool, got {readings}")
    references: list[BeamReading] = []
    for tool in tools:
        if tool not in POINTERS:
            continue
        change_tool_safely(controller, tool)
        for _ in range(readings):
            reading = read_beam(controller, SWEEP_M)
            if reading is not None:
                references.append(reading)
        controller.move_joints(controller.q_home)
        controller.return_tool()
    controller.move_joints(controller.q_home)
    return Commissioning(cell, tuple(references))
