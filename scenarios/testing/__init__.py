"""End-to-end cell tests for the user's own cell: twincell as a pytest plugin (plugin.py,
registered by the package's `pytest11` entry point: `pip install twincell` is enough) and the
assertions a test states of a run (asserts.py).

    def test_my_program(run_job, twincell_seed):
        run = run_job("my_cell.yaml", seed=twincell_seed)
        assert_goals(run)
        assert_targets_within(run, 0.5e-3)
"""

from scenarios.testing.asserts import (
    assert_detected,
    assert_goals,
    assert_targets_within,
)
from scenarios.testing.runs import JobRun

__all__ = ["JobRun", "assert_detected", "assert_goals", "assert_targets_within"]
