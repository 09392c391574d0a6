"""The shift's recording (shift.rrd): its jobs on one timeline, `shift_time` (the shift's
clock, from its start): each job's target errors, the check's drift and bound, the arm's
warm-up shift (truth), its cell time and what it did with the calibration, at the job's
start. Each job's own recording (its run.rrd, on the cell's clock) is in its run folder."""

from __future__ import annotations

import os
from pathlib import Path

import rerun as rr
import rerun.blueprint as rrb

from scenarios.results.shift_result import ShiftResult

SHIFT_TIME = "shift_time"


def _layout(hours: float) -> rrb.Blueprint:
    """The viewer's layout: the target errors, the check, the warm-up, the links' growth and
    the cell time over the whole shift (`hours` long), and the jobs' log."""
    whole = rrb.archetypes.TimeAxis(
        view_range=rr.encodings.TimeRange(
            start=rrb.TimeRangeBoundary.absolute(seconds=0.0),
            end=rrb.TimeRangeBoundary.absolute(seconds=hours * 3600.0),
        )
    )

    def plot(entity: str, name: str) -> rrb.TimeSeriesView:
        return rrb.TimeSeriesView(origin=f"/shift/{entity}", name=name, axis_x=whole)

    return rrb.Blueprint(
        rrb.Vertical(
            plot("target_error_mm", "target error [mm]"),
            plot("check_mm", "check: drift and bound [mm]"),
            rrb.Horizontal(
                plot("warmup_j2_mrad", "joint 2 warm-up [mrad]"),
                plot("links_growth_um_per_m", "links' growth [um/m]"),
                plot("cell_time_s", "cell time [s]"),
            ),
            rrb.TextLogView(origin="/shift/jobs", name="jobs"),
        ),
        collapse_panels=True,
    )


def write_shift_recording(path: Path, result: ShiftResult) -> Path:
    """The recording, written to a temporary name and moved into place."""
    tmp = path.with_name(f".{path.name}.partial")
    stream = rr.RecordingStream("twincell")
    stream.save(str(tmp), default_blueprint=_layout(result.hours))
    stream.send_recording_name(
        f"{result.job} shift on the {result.robot} (seed {result.seed}, policy {result.policy})"
    )
    stream.set_log_time_enabled(False)
    times = rr.TimeColumn(SHIFT_TIME, duration=result.column("start_h", 3600.0))
    series = {
        "shift/target_error_mm/rms": result.column("target_rms_m", 1e3),
        "shift/target_error_mm/max": result.column("target_max_m", 1e3),
        "shift/target_error_mm/exported_rms": result.column("exported_rms_m", 1e3),
        "shift/check_mm/drift": result.column("check_drift_m", 1e3),
        "shift/check_mm/bound": result.column("check_bound_m", 1e3),
        "shift/warmup_j2_mrad": result.column("warmup_j2_rad", 1e3),
        "shift/links_growth_um_per_m": result.column("thermal_strain", 1e6),
        "shift/cell_time_s": result.column("cell_time_s"),
    }  # fmt: skip
    for entity, values in series.items():
        stream.send_columns(entity, indexes=[times], columns=rr.Scalars.columns(scalars=values))
    for job in result.jobs:
        stream.set_time(SHIFT_TIME, duration=job.start_h * 3600.0)
        stream.log(
            "shift/jobs",
            rr.TextLog(f"job {job.job}: {job.status}, calibration {job.calibration}: {job.folder}"),
        )
    stream.flush()
    stream.disconnect()
    os.replace(tmp, path)
    return path
