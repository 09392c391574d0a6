"""The README's per-seed tables of the skull job (built-in cell, the calibration's gains by
group, UR5 cell) and the assembly job, rerun.

Usage: python bench/readme_tables.py [--seeds 8] [--group-seeds 4] [--write]
Prints the four tables (each seed as it finishes); with --write, puts them into README.md
between their `<!-- table:skull -->`, `<!-- table:groups -->`, `<!-- table:ur5 -->` and
`<!-- table:assembly -->` markers. The run time column is the wall time of each assembly run
on this machine.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from scenarios.jobs.tables import (
    ASSEMBLY_HEADER,
    GROUPS_HEADER,
    SKULL_HEADER,
    UR5_HEADER,
    assembly_rows,
    groups_rows,
    replace_table,
    skull_rows,
    ur5_rows,
)

README = Path(__file__).resolve().parent.parent / "README.md"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=8, help="seeds 0 .. N-1")
    parser.add_argument("--group-seeds", type=int, default=4, help="seeds of the gains table")
    parser.add_argument("--write", action="store_true", help="write the tables into README.md")
    args = parser.parse_args()
    seeds = range(args.seeds)
    print(SKULL_HEADER)
    skull = skull_rows(seeds, say=print)
    print()
    print(GROUPS_HEADER)
    groups = groups_rows(range(args.group_seeds), say=print)
    print()
    print(UR5_HEADER)
    ur5 = ur5_rows(seeds, say=print)
    print()
    print(ASSEMBLY_HEADER)
    assembly = assembly_rows(seeds, say=print)
    if args.write:
        text = README.read_text()
        text = replace_table(text, "skull", SKULL_HEADER, skull)
        text = replace_table(text, "groups", GROUPS_HEADER, groups)
        text = replace_table(text, "ur5", UR5_HEADER, ur5)
        text = replace_table(text, "assembly", ASSEMBLY_HEADER, assembly)
        README.write_text(text)
        print(f"written into {README}")


if __name__ == "__main__":
    main()
