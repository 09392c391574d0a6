"""The README's per-seed tables of the skull job (in the built-in cell, its calibration's
gains group by group, and in the UR5 cell) and of the assembly job, made from runs.

`python bench/readme_tables.py` runs the jobs and prints (or, with --write, puts into
README.md between the `<!-- table:NAME -->` markers) the tables; a test reruns a few seeds
and compares them with the README's rows.
"""

from __future__ import annotations

import re
import tempfile
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from scenarios.jobs.runner import RunOptions, run_job

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


def _pair(results: dict[str, Any], key: str | None = None) -> str:
    """RMS / max [mm] of a run's target errors (its own, or those of `key`'s section)."""
    section = results if key is None else (results.get(key) or {})
    return f"{_mm(section.get('target_error_rms_m'))} / {_mm(section.get('target_error_max_m'))}"


def skull_row(
    seed: int, default: dict[str, Any], nominal: dict[str, Any], off: dict[str, Any]
) -> str:
    """One seed of the skull table from three runs: the shipped configuration (the program
    exported filtered and executed at the end), the program exported as programmed
    (export.compensation nominal), and the job without its calibration."""
    c = default["calibration"]
    return (
        f"| {seed} | {_pair(default, 'exported_program')} | {_pair(nominal, 'exported_program')}"
        f" | {_pair(default)} | {_pair(off)} | {_mm(c['tcp_error_nominal_mean_m'])} / "
        f"{_mm(c['tcp_error_calibrated_mean_m'], 3)} |"
    )


def ur5_row(seed: int, calibrated: dict[str, Any], nominal: dict[str, Any]) -> str:
    """One seed of the UR5 skull table from the results of a run with the calibration and
    one without (calibration.enabled false)."""
    c = calibrated["calibration"]
    return (
        f"| {seed:<4d} | {_mm(calibrated['target_error_rms_m'])} / "
        f"{_mm(calibrated['target_error_max_m'])} | {_mm(nominal['target_error_rms_m'])} / "
        f"{_mm(nominal['target_error_max_m'])} | {_mm(c['tcp_error_nominal_mean_m'])} / "
        f"{_mm(c['tcp_error_nominal_max_m'])} | {_mm(c['tcp_error_calibrated_mean_m'], 3)} / "
        f"{_mm(c['tcp_error_calibrated_max_m'], 3)} |"
    )


def assembly_row(seed: int, results: dict[str, Any]) -> str:
    """One seed of the assembly table from a run's results."""
    m = results["methods"]
    a, b, p = m["surface"], m["probe"], results["pick"]
    return (
        f"| {seed} | {a['rotation_error_deg']:.3f}, {_mm(a['translation_error_m'])} | "
        f"{b['rotation_error_deg']:.3f}, {_mm(b['translation_error_m'])} | "
        f"{_mm(a['target_error_rms_m'])} / {_mm(a['target_error_max_m'])} | "
        f"{_mm(b['target_error_rms_m'])} / {_mm(b['target_error_max_m'])} | "
        f"{_pair(results, 'exported_program')} | {_mm(p['lifted_m'])} | {_mm(p['slip_m'])} | "
        f"{_mm(p['placed_displacement_m'])} / "
        f"{p['placed_rotation_deg']:.3f} | {results['seconds']:.1f} |"
    )


def _run(
    name: str,
    seed: int,
    out: Path,
    overrides: dict[str, Any] | None = None,
    cell: str | None = None,
) -> dict:
    _, results = run_job(name, seed=seed, out=out, overrides=overrides,
                         options=RunOptions(rrd=False), cell=cell)  # fmt: skip
    return results


def skull_rows(seeds: Iterable[int], say: Progress | None = None) -> list[str]:
    """The skull table's rows for `seeds` (three runs each, see `skull_row`)."""
    rows = []
    with tempfile.TemporaryDirectory(prefix="twincell-tables-") as tmp:
        for seed in seeds:
            default = _run("skull", seed, Path(tmp))
            nominal = _run("skull", seed, Path(tmp), {"export.compensation": "nominal"})
            off = _run("skull", seed, Path(tmp), {"calibration.enabled": False})
            rows.append(skull_row(seed, default, nominal, off))
            if say is not None:
                say(rows[-1])
    return rows


def ur5_rows(seeds: Iterable[int], say: Progress | None = None) -> list[str]:
    """The UR5 skull table's rows for `seeds` (two runs each: calibrated, nominal arm)."""
    rows = []
    with tempfile.TemporaryDirectory(prefix="twincell-tables-") as tmp:
        for seed in seeds:
            calibrated = _run("skull", seed, Path(tmp), cell="ur5")
            nominal = _run("skull", seed, Path(tmp), {"calibration.enabled": False}, "ur5")
            rows.append(ur5_row(seed, calibrated, nominal))
            if say is not None:
                say(rows[-1])
    return rows


def groups_rows(seeds: Iterable[int], say: Progress | None = None) -> list[str]:
    """The calibration gains table's rows: per seed, the exported filtered program's target
    RMS / max [mm] on a controller without absolute accuracy, the calibration identifying
    the groups of GROUP_STEPS."""
    rows = []
    with tempfile.TemporaryDirectory(prefix="twincell-tables-") as tmp:
        for seed in seeds:
            cells = [
                _pair(
                    _run("skull", seed, Path(tmp), {"calibration.identify": list(step)}),
                    "exported_program",
                )
                for step in GROUP_STEPS
            ]
            rows.append(f"| {seed} | " + " | ".join(cells) + " |")
            if say is not None:
                say(rows[-1])
    return rows


def assembly_rows(seeds: Iterable[int], say: Progress | None = None) -> list[str]:
    """The assembly table's rows for `seeds`."""
    rows = []
    with tempfile.TemporaryDirectory(prefix="twincell-tables-") as tmp:
        for seed in seeds:
            rows.append(assembly_row(seed, _run("assembly", seed, Path(tmp))))
            if say is not None:
                say(rows[-1])
    return rows


def _span(name: str) -> re.Pattern[str]:
    return re.compile(rf"(<!-- table:{name} -->\n)(.*?)(<!-- /table:{name} -->)", re.DOTALL)


def readme_table(readme: str, name: str) -> list[str]:
    """The rows of the README's table `name` (between its markers), header excluded."""
    found = _span(name).search(readme)
    if found is None:
        raise ValueError(f"README has no table {name!r} (<!-- table:{name} --> markers)")
    lines = [line for line in found.group(2).splitlines() if line.startswith("|")]
    return lines[2:]


def replace_table(readme: str, name: str, header: str, rows: list[str]) -> str:
    """The README with table `name` replaced by `header` and `rows`."""
    body = header + "\n" + "\n".join(rows) + "\n"
    return _span(name).sub(lambda m: m.group(1) + body + m.group(3), readme)


def numbers(row: str) -> list[float]:
    """The numbers of a table row, in order (the seed first)."""
    return [float(x) for x in re.findall(r"-?\d+\.?\d*", row)]
