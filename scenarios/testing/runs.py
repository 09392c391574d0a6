"""A job's run as a test sees it: the typed result, the run folder, and how to look at it."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from scenarios.results.run import RunResult


@dataclass(frozen=True, eq=False)
class JobRun:
    """A run of `twincell run`: its result (what results.json holds) and its folder."""

    result: RunResult
    folder: Path

    @property
    def seed(self) -> int:
        return self.result.seed

    @property
    def job(self) -> str:
        return self.result.job

    @property
    def look(self) -> str:
        """Where to look at it: the run folder and the recording's command."""
        rrd = self.folder / "run.rrd"
        seen = (
            f"; look at it: rerun {rrd}" if rrd.is_file() else " (no recording: --twincell-no-rrd)"
        )
        return f"run folder {self.folder}{seen}"

    def title(self) -> str:
        return f"job {self.job}, seed {self.seed}"
