"""The per-seed tables of the skull job (in the built-in cell, its calibration's gains group
by group, and in the UR5 cell) and of the assembly job, made from runs.

`python bench/readme_tables.py` runs the jobs and prints (or, with --write, puts into
docs/benchmarks.md between the `<!-- table:NAME -->` markers) the tables; a test reruns a
few seeds and compares them with the page's rows.
"""

from __future__ import annotations

import re
import tempfile
from collections.abc import Callable, Iterable
from pathlib import Path

from scenarios.jobs.runner import RunOptions, run_job
from scenarios.results.method_reports import MethodReport
from scenarios.results.results_file import read_results
from scenarios.results.run import RunResult
from scenarios.scenario_errors import ScenarioError

Progress = Callable[[str], None]

SKULL_HEADER = (
    "| seed | program.mod on a controller without absolute accuracy: filtered, RMS / max "
    "[mm] | as programmed [mm] | the job's own execution, calibrated [mm] | calibration off "
    "[mm] | TCP error nominal / calibrated, mean [mm] |\n"
    "|---:|---:|---:|---:|---:|---:|"
)
UR5_HEADER = (
    "| seed | target RMS / max, calibrated [mm] | nominal arm [mm] | TCP error nominal [mm] "
    "| calibrated [mm] |\n"
    "|-----:|----------------------------------:|-----------------:|-----------------------:"
    "|----------------:|"
)
#: The calibration's groups, added one by one (the gains table).
GROUP_STEPS: tuple[tuple[str, ...], ...] = (
    ("arm",),
    ("arm", "stiffness"),
    ("arm", "stiffness", "laser"),
    ("arm", "stiffness", "laser", "table"),
)
GROUPS_HEADER = (
    "| seed | arm | + joint stiffness | + laser mounting and scale | + table axis (all) |\n"
    "|---:|---:|---:|---:|---:|"
)
ASSEMBLY_HEADER = (
    "| seed | 3D pose error [deg, mm] | 2D pose error [deg, mm] | screws 3D, RMS / max [mm] "
    "| screws 2D, RMS / max [mm] | program.mod filtered, RMS / max [mm] | lifted [mm] | "
    "slip [mm] | put-down moved [mm] / turned [deg] | run [s] |\n"
    "|---:|---|---|---|---|---|---:|---:|---|---:|"
)


def _mm(x: float | None, digits: int = 2) -> str:
    return "-" if x is None else f"{x * 1e3:.{digits}f}"


def _pair(rms_m: float | None, max_m: float | None) -> str:
    """RMS / max [mm] of target errors."""
    return f"{_mm(rms_m)} / {_mm(max_m)}"


def _own(result: RunResult) -> str:
    """The run's own target errors, RMS / max [mm]."""
    return _pair(result.target_error_rms_m, result.target_error_max_m)


def _exported(result: RunResult) -> str:
    """The exported program's target errors on the nominal controller, RMS / max [mm]."""
    e = result.exported_program
    return "- / -" if e is None else _pair(e.target_error_rms_m, e.target_error_max_m)


def _tcp_mean(result: RunResult, calibrated: bool = False) -> float | None:
    """The arm's true TCP error, mean [m], of the nominal (or calibrated) arm."""
    c = result.calibration
    error = c.calibrated if calibrated else c.nominal
    return None if error is None else error.mean_m


def skull_row(seed: int, default: RunResult, nominal: RunResult, off: RunResult) -> str:
    """One seed of the skull table from three runs: the shipped configuration (the program
    exported filtered and executed at the end), the program exported as programmed
    (export.compensation nominal), and the job without its calibration."""
    return (
        f"| {seed} | {_exported(default)} | {_exported(nominal)}"
        f" | {_own(default)} | {_own(off)} | {_mm(_tcp_mean(default))} / "
        f"{_mm(_tcp_mean(default, calibrated=True), 3)} |"
    )


def ur5_row(seed: int, calibrated: RunResult, nominal: RunResult) -> str:
    """One seed of the UR5 skull table from the results of a run with the calibration and
    one without (calibration.enabled false)."""
    c = calibrated.calibration
    tcp = c.calibrated
    return (
        f"| {seed:<4d} | {_own(calibrated)} | {_own(nominal)} | {_mm(c.nominal.mean_m)} / "
        f"{_mm(c.nominal.max_m)} | {_mm(None if tcp is None else tcp.mean_m, 3)} / "
        f"{_mm(None if tcp is None else tcp.max_m, 3)} |"
    )


def _pose(report: MethodReport | None) -> str:
    pose = None if report is None else report.pose
    if pose is None:
        return "-"
    return f"{pose.rotation_error_deg:.3f}, {_mm(pose.translation_error_m)}"


def _targets(report: MethodReport | None) -> str:
    return "- / -" if report is None else _pair(report.rms_m, report.max_m)


def assembly_row(seed: int, result: RunResult) -> str:
    """One seed of the assembly table from a run's results."""
    a, b, p = result.method("surface"), result.method("probe"), result.pick
    if p is None:
        raise ValueError(f"the assembly run of seed {seed} did not pick: {result.reason}")
    return (
        f"| {seed} | {_pose(a)} | {_pose(b)} | {_targets(a)} | {_targets(b)} | "
        f"{_exported(result)} | {_mm(p.lifted_m)} | {_mm(p.slip_m)} | "
        f"{_mm(p.placed_displacement_m)} / {p.placed_rotation_deg:.3f} | "
        f"{result.seconds or 0.0:.1f} |"
    )


def _run(
    name: str,
    seed: int,
    out: Path,
    overrides: dict[str, object] | None = None,
    cell: str | None = None,
) -> RunResult:
    """A run of the job `name`, its result read back from its results.json."""
    folder, _ = run_job(name, seed=seed, out=out, overrides=overrides,
                        options=RunOptions(rrd=False), cell=cell)  # fmt: skip
    return read_results(folder)


def _rows(seeds: Iterable[int], row: Callable[[int, Path], str], say: Progress | None) -> list[str]:
    """`row(seed, folder)` for each of `seeds`, the runs in one scratch folder, each row said
    as it is made."""
    rows = []
    with tempfile.TemporaryDirectory(prefix="twincell-tables-") as tmp:
        for seed in seeds:
            rows.append(row(seed, Path(tmp)))
            if say is not None:
                say(rows[-1])
    return rows


def skull_rows(seeds: Iterable[int], say: Progress | None = None) -> list[str]:
    """The skull table's rows for `seeds` (three runs each, see `skull_row`)."""

    def row(seed: int, tmp: Path) -> str:
        default = _run("skull", seed, tmp)
        nominal = _run("skull", seed, tmp, {"export.compensation": "nominal"})
        off = _run("skull", seed, tmp, {"calibration.enabled": False})
        return skull_row(seed, default, nominal, off)

    return _rows(seeds, row, say)


def ur5_rows(seeds: Iterable[int], say: Progress | None = None) -> list[str]:
    """The UR5 skull table's rows for `seeds` (two runs each: calibrated, nominal arm)."""

    def row(seed: int, tmp: Path) -> str:
        calibrated = _run("skull", seed, tmp, cell="ur5")
        nominal = _run("skull", seed, tmp, {"calibration.enabled": False}, "ur5")
        return ur5_row(seed, calibrated, nominal)

    return _rows(seeds, row, say)


#: The TCP check's tolerance in the calibration gains table's runs [m] (see groups_rows).
GROUPS_TOOL_TOLERANCE_M = 7.5e-4


def groups_rows(seeds: Iterable[int], say: Progress | None = None) -> list[str]:
    """The calibration gains table's rows: per seed, the exported filtered program's target
    RMS / max [mm] on a controller without absolute accuracy, the calibration identifying
    the groups of GROUP_STEPS. The TCP check is held to GROUPS_TOOL_TOLERANCE_M: an arm
    calibrated on fewer groups reads more at the beam than a fully calibrated one, and the
    table shows what its program achieves rather than the check stopping it."""

    def row(seed: int, tmp: Path) -> str:
        cells = [
            _exported(
                _run("skull", seed, tmp, {"calibration.identify": list(step),
                                          "verify.tool_tolerance_m": GROUPS_TOOL_TOLERANCE_M})
            )
            for step in GROUP_STEPS
        ]  # fmt: skip
        return f"| {seed} | " + " | ".join(cells) + " |"

    return _rows(seeds, row, say)


def assembly_rows(seeds: Iterable[int], say: Progress | None = None) -> list[str]:
    """The assembly table's rows for `seeds`."""
    return _rows(seeds, lambda seed, tmp: assembly_row(seed, _run("assembly", seed, tmp)), say)


#: The file arms' table: arms given by file, flange and mount alone (the ur5 cell's layout).
FILE_ARMS_HEADER = (
    "| arm | seed | home chosen [deg] | target RMS / max [mm] | goals |\n"
    "|:----|-----:|:------------------|-----------------------:|:------|"
)
#: The layout the file arms are tried in: cells/ur5.yaml's.
FILE_ARM_LAYOUT: dict[str, object] = {
    "cell.robot.mount_xyz": [0.55, -0.1, 0.45],
    "cell.rack_xyz": [0.2, -0.8, -0.1],
    "cell.object.placement.xy_m": [-0.15, 0.0],
}


def file_arm_rows(
    arms: Iterable[tuple[str, Path, str]], seeds: Iterable[int], say: Progress | None = None
) -> list[str]:
    """The file arms' table: for each arm (label, file, flange frame) and seed, the home the
    cell chose and the skull job's target RMS / max against the true targets."""
    rows = []
    seeds = list(seeds)
    with tempfile.TemporaryDirectory(prefix="twincell-tables-") as tmp:
        for label, path, flange in arms:
            overrides = FILE_ARM_LAYOUT | {"cell.robot.model": str(path),
                                           "cell.robot.flange": flange}  # fmt: skip
            for seed in seeds:
                try:
                    result = _run("skull", seed, Path(tmp), overrides)
                except ScenarioError as exc:  # refused before the cell starts
                    rows.append(f"| {label} | {seed} | - | - / - | refused: {exc} |")
                else:
                    home = ", ".join(f"{v:.0f}" for v in result.home_deg)
                    met = all(check.met for check in result.checks.values())
                    rows.append(
                        f"| {label} | {seed} | [{home}] | {_own(result)} | "
                        f"{'met' if met else 'missed'} ({result.status}) |"
                    )
                if say is not None:
                    say(rows[-1])
    return rows


def _span(name: str) -> re.Pattern[str]:
    return re.compile(rf"(<!-- table:{name} -->\n)(.*?)(<!-- /table:{name} -->)", re.DOTALL)


def readme_table(readme: str, name: str) -> list[str]:
    """The rows of a page's table `name` (between its markers), header excluded."""
    found = _span(name).search(readme)
    if found is None:
        raise ValueError(f"no table {name!r} in the page (<!-- table:{name} --> markers)")
    lines = [line for line in found.group(2).splitlines() if line.startswith("|")]
    return lines[2:]


def replace_table(readme: str, name: str, header: str, rows: list[str]) -> str:
    """The page `readme` with table `name` replaced by `header` and `rows`."""
    body = header + "\n" + "\n".join(rows) + "\n"
    return _span(name).sub(lambda m: m.group(1) + body + m.group(3), readme)


def numbers(row: str) -> list[float]:
    """The numbers of a table row, in order (the seed first)."""
    return [float(x) for x in re.findall(r"-?\d+\.?\d*", row)]
