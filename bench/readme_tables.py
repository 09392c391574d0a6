"""The per-seed tables of docs/benchmarks.md, rerun: the skull job (built-in cell, the
calibration's gains by group, UR5 cell, file arms) and the assembly job.

Usage: python bench/readme_tables.py [--seeds 8] [--group-seeds 4] [--arm-seeds 5]
       [--tables NAME ...] [--write] [--short]
Prints the tables (each seed as it finishes; all five unless --tables names some); with
--write, puts them into docs/benchmarks.md between their `<!-- table:skull -->`,
`<!-- table:groups -->`, `<!-- table:ur5 -->`, `<!-- table:file_arms -->` and
`<!-- table:assembly -->` markers. The run time column is the wall time of each assembly run
on this machine. The file arms are example-robot-data's UR10 and the Menagerie files in
bench/arms/, each given by file, flange and mount alone.

--short: seed 0 of the assembly table alone (one run; tests/test_readme_tables.py reruns
seed 0 of every table against the page's rows); it writes nothing.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Iterable
from pathlib import Path

from bench_support.readme_table_rows import (
    ASSEMBLY_HEADER,
    FILE_ARMS_HEADER,
    GROUPS_HEADER,
    SKULL_HEADER,
    UR5_HEADER,
    Progress,
    assembly_rows,
    file_arm_rows,
    groups_rows,
    replace_table,
    skull_rows,
    ur5_rows,
)

from cell.ur5_arm import example_robot_data_share

PAGE = Path(__file__).resolve().parent.parent / "docs" / "benchmarks.md"
ARMS = Path(__file__).resolve().parent / "arms"


def file_arms() -> tuple[tuple[str, Path, str], ...]:
    """The arms of the file arms' table: label, file, flange frame."""
    ur10 = example_robot_data_share() / "example-robot-data/robots/ur_description/urdf"
    return (
        ("UR10 (example-robot-data, URDF)", ur10 / "ur10_robot.urdf", "tool0"),
        ("UR10e (Menagerie, MJCF)", ARMS / "universal_robots_ur10e/ur10e.xml", "attachment_site"),
        ("UR5e (Menagerie, MJCF)", ARMS / "universal_robots_ur5e/ur5e.xml", "attachment_site"),
        ("M1013 (Menagerie, MJCF)", ARMS / "doosan_robotics_m1013/m1013.xml", "link_6"),
    )


def file_arm_table(seeds: Iterable[int], say: Progress | None) -> list[str]:
    return file_arm_rows(file_arms(), seeds, say)


Rows = Callable[[Iterable[int], Progress | None], list[str]]
#: Each table: its header and the function that makes its rows, in the page's order.
TABLES: dict[str, tuple[str, Rows]] = {
    "skull": (SKULL_HEADER, skull_rows),
    "groups": (GROUPS_HEADER, groups_rows),
    "ur5": (UR5_HEADER, ur5_rows),
    "file_arms": (FILE_ARMS_HEADER, file_arm_table),
    "assembly": (ASSEMBLY_HEADER, assembly_rows),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=8, help="seeds 0 .. N-1")
    parser.add_argument("--group-seeds", type=int, default=4, help="seeds of the gains table")
    parser.add_argument("--arm-seeds", type=int, default=5, help="seeds of the file arms")
    parser.add_argument("--tables", nargs="+", choices=list(TABLES), default=list(TABLES))
    parser.add_argument(
        "--write", action="store_true", help="write the tables into docs/benchmarks.md"
    )
    parser.add_argument("--short", action="store_true", help="seed 0 of the assembly table")
    args = parser.parse_args()
    if args.short:
        if args.write:
            parser.error("--short writes nothing: leave out --write")
        args.seeds, args.tables = 1, ["assembly"]
    made = {}
    for name in args.tables:
        header, rows = TABLES[name]
        count = {"groups": args.group_seeds, "file_arms": args.arm_seeds}.get(name, args.seeds)
        seeds = range(count)
        if made:
            print()
        print(header)
        made[name] = rows(seeds, print)
    if args.write:
        text = PAGE.read_text()
        for name, rows_made in made.items():
            text = replace_table(text, name, TABLES[name][0], rows_made)
        PAGE.write_text(text)
        print(f"written into {PAGE}")


if __name__ == "__main__":
    main()
