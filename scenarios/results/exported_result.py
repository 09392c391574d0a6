"""The exported program (program.mod) as a controller without absolute accuracy ran it at
the end of the job, in results.json's words: its status, and if it ran, each target's
error."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

ExportedStatus = Literal["complete", "refused", "aborted"]


@dataclass(frozen=True)
class TargetError:
    """A target's name and the achieved tool tip's distance from the true target [m]."""

    name: str
    error_m: float


@dataclass(frozen=True)
class ExportedRun:
    """The exported program's run: "complete" (with the program's file, what its targets
    were compensated for, the targets' errors [m]), "refused" by the controller (a RAPID
    error) or "aborted" by its supervision, with the `reason`."""

    status: ExportedStatus
    reason: str = ""
    program: str = ""
    compensation: str = ""
    target_error_rms_m: float | None = None
    target_error_max_m: float | None = None
    targets: tuple[TargetError, ...] = ()
