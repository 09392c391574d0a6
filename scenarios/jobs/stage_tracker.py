"""The stage a run is in: set by the job as it goes, read by the runner when the run stops
early (an error, a signal), so that results.json says where it stopped."""

from __future__ import annotations

SETUP = "setup"
"""The stage of a run until its job enters another: the configuration, the models, the cell."""


class StageTracker:
    """The current stage of one run, by name (`current`): "setup" at first, then each stage
    the job enters; a cell job's are "calibrate", "probe", "scan", "register", "check",
    "verify", "execute" and "export" (scenarios.jobs.pipeline), those it runs, in that
    order."""

    def __init__(self, initial: str = SETUP) -> None:
        self.current = initial

    def enter(self, name: str) -> None:
        """The run begins the stage `name` (a non-empty word)."""
        if not isinstance(name, str) or not name.strip():
            raise ValueError(f"a stage is named by a non-empty string, got {name!r}")
        self.current = name

    def __repr__(self) -> str:
        return f"StageTracker(current={self.current!r})"
