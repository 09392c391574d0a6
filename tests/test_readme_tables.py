"""The README's per-seed tables hold: seed 0 of the skull job (its program on a controller
without absolute accuracy filtered and as programmed, its own execution, without the
calibration; the calibration's gains group by group; in the UR5 cell) and of the assembly
job, rerun, gives the README's rows within their printed precision (run times aside)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from scenarios.jobs.tables import (
    assembly_rows,
    groups_rows,
    numbers,
    readme_table,
    skull_rows,
    ur5_rows,
)

#: Each test reruns the jobs of a README row: one (assembly) to four (the groups).
pytestmark = pytest.mark.slow

README = (Path(__file__).resolve().parent.parent / "README.md").read_text()


def _close(fresh: str, printed: str, columns: slice) -> None:
    a, b = np.array(numbers(fresh))[columns], np.array(numbers(printed))[columns]
    assert a.shape == b.shape, (fresh, printed)
    # Two decimals [mm or deg] are printed: the rerun agrees to the last digit but one.
    np.testing.assert_allclose(a, b, atol=0.021, err_msg=f"\n{fresh}\n{printed}")


def test_skull_table_seed_0() -> None:
    (fresh,) = skull_rows([0])
    printed = readme_table(README, "skull")[0]
    _close(fresh, printed, slice(None))


def test_groups_table_seed_0() -> None:
    (fresh,) = groups_rows([0])
    printed = readme_table(README, "groups")[0]
    _close(fresh, printed, slice(None))


def test_ur5_table_seed_0() -> None:
    (fresh,) = ur5_rows([0])
    printed = readme_table(README, "ur5")[0]
    _close(fresh, printed, slice(None))


def test_assembly_table_seed_0() -> None:
    (fresh,) = assembly_rows([0])
    printed = readme_table(README, "assembly")[0]
    _close(fresh, printed, slice(0, -1))  # the last column is the run's wall time
