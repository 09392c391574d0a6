"""The verification in the recording, logged when it is decided (before the first touch).

At each target, under the table frame, a marker coloured by its decision (green: agrees,
red: moved or inconsistent, orange: not resolved) labelled with the move measured, its
bound and the allowance; the strips scanned again, in grey; bar charts of the moves and
the allowances in mm; one log line per verification. Each tool's check at the beam: its
reading, four standard deviations and the offset it calls off beyond, in mm, and a log line.
"""

from __future__ import annotations

import numpy as np
import rerun as rr

from scenarios.realcell.recording.stream import Stream
from scenarios.results.verification_result import TcpCheck, Verification

COLOURS = {
    "agrees": (40, 200, 60),
    "moved": (230, 30, 30),
    "inconsistent": (230, 30, 30),
    "unresolved": (255, 150, 0),
}


def log_verification(
    stream: Stream,
    time_s: float,
    verification: Verification,
    targets_table: np.ndarray,
    strip_table: np.ndarray,
    table_path: str,
) -> None:
    """The `verification` at `time_s`: its targets (K, 3) and the strips' points (N, 3) [m]
    in the table frame believed (entity `table_path`)."""
    stream.at(sim_time=time_s)
    if len(strip_table):
        stream.log(
            f"{table_path}/verify/strips",
            rr.Points3D(strip_table[::4], radii=0.0003, colors=[[150, 150, 150]]),
        )
    checks = verification.checks
    if not checks:
        return
    labels = [
        f"{c.name}: moved {c.moved_m * 1e3:.3f} ± {c.uncertainty_m * 1e3:.3f} mm "
        f"(allowed {c.allowance_m * 1e3:.3f}): {c.decision}"
        for c in checks
    ]
    stream.log(
        f"{table_path}/verify/targets",
        rr.Points3D(
            targets_table,
            radii=0.0015,
            colors=[COLOURS[c.decision] for c in checks],
            labels=labels,
            show_labels=True,
        ),
    )
    stream.log(
        "plots/verify/moved_mm",
        rr.BarChart(np.array([c.moved_m for c in checks]) * 1e3, color=[230, 30, 30]),
    )
    stream.log(
        "plots/verify/allowance_mm",
        rr.BarChart(np.array([c.allowance_m for c in checks]) * 1e3, color=[40, 200, 60]),
    )
    level = "INFO" if verification.agrees else "WARN"
    stream.log("log", rr.TextLog(f"verify: {verification.summary()}", level=level))


TOOL_COLOURS = {"seated": (40, 200, 60), "off": (230, 30, 30), "unresolved": (255, 150, 0)}


def log_tool_check(stream: Stream, time_s: float, check: TcpCheck) -> None:
    """A tool checked at the beam at `time_s`: its offset read, its uncertainty and the
    offset it calls off beyond, as bars in mm (`plots/tool_check`), and a log line, a
    warning when the tool is called off."""
    stream.at(sim_time=time_s)
    finite = bool(np.isfinite(check.off_m))
    bars = [check.off_m if finite else 0.0, 4.0 * check.sigma_m, check.resolves_m]
    colour = TOOL_COLOURS[check.decision]
    stream.log("plots/tool_check", rr.BarChart(np.array(bars) * 1e3, color=list(colour)))
    level = "INFO" if check.ok else "WARN"
    text = f"TCP check, attempt {check.attempt + 1}: {check.verdict}: {check.summary()}"
    stream.log("log", rr.TextLog(text, level=level))
