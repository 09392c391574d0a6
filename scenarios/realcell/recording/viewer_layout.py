"""The recording's default layout: what a user sees on opening run.rrd.

Left, the object close up (the scan, the virtual model moving to its registered pose, the
targets; the real object and the arm left out, they would hide the fit) above the whole
cell (the real cell, the laser's rays). Right, the plots (target errors and predicted TRE
per target, the ICP's RMS on the `icp` timeline), the colour scale and the run's log.
A served cell (`twincell serve`) has a layout of its own: the cell, and its event log.
"""

from __future__ import annotations

import numpy as np
import rerun.blueprint as rrb

from scenarios.realcell.recording.stream import SIM_TIME


def blueprint(
    object_entity: str | None = None,
    eye_object: tuple[np.ndarray, np.ndarray] | None = None,
    eye_cell: tuple[np.ndarray, np.ndarray] | None = None,
) -> rrb.Blueprint:
    """The layout; `eye_*` (position, look target) [m] in the base frame place the cameras;
    `object_entity` is the real object's entity, left out of the close-up."""

    def eye(spot: tuple[np.ndarray, np.ndarray] | None) -> rrb.EyeControls3D | None:
        if spot is None:
            return None
        return rrb.EyeControls3D(position=spot[0], look_target=spot[1], eye_up=(0.0, 0.0, 1.0))

    hidden = ["- /world/cell/arm/**", "- /world/cell/rack/**", "- /world/cell/table_rail/**"]
    if object_entity is not None:
        hidden.append(f"- /{object_entity}/**")
    close_up = rrb.Spatial3DView(
        origin="/world",
        contents=["+ /world/**", *hidden],
        name="object: scan, registered model, targets",
        eye_controls=eye(eye_object),
        line_grid=rrb.archetypes.LineGrid3D(visible=False),
    )
    cell = rrb.Spatial3DView(origin="/world", name="cell", eye_controls=eye(eye_cell))
    plots = rrb.Vertical(
        rrb.Tabs(
            rrb.BarChartView(origin="/plots/targets/error_mm", name="target error [mm]"),
            rrb.BarChartView(
                origin="/plots/budget/bound_mm", name="error budget: bound per target [mm]"
            ),
            rrb.BarChartView(origin="/plots/targets/predicted_tre_mm", name="predicted TRE [mm]"),
            rrb.BarChartView(origin="/plots/verify/moved_mm", name="verify: moved [mm]"),
            rrb.BarChartView(origin="/plots/verify/allowance_mm", name="verify: allowed [mm]"),
            rrb.BarChartView(
                origin="/plots/tool_check",
                name="TCP check: read, 4 sigma, called off beyond [mm]",
            ),
        ),
        rrb.Tabs(
            rrb.BarChartView(
                origin="/plots/icp/rms_per_iteration_mm", name="ICP rms [mm] per iteration"
            ),
            rrb.TimeSeriesView(origin="/plots/icp/rms_mm", name="ICP rms [mm] (timeline icp)"),
            rrb.BarChartView(
                origin="/plots/calibration/residual_per_view_mm",
                name="calibration rms [mm] per view",
            ),
        ),
        rrb.Spatial2DView(origin="/legend", name="colour scale"),
        rrb.TextLogView(origin="/log", name="log"),
        row_shares=[2, 2, 1, 3],
    )
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(close_up, cell, row_shares=[3, 2]), plots, column_shares=[3, 2]
        ),
        rrb.TimePanel(timeline=SIM_TIME, state="expanded"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.BlueprintPanel(state="collapsed"),
    )


def serve_blueprint(eye_cell: tuple[np.ndarray, np.ndarray] | None = None) -> rrb.Blueprint:
    """The layout of a served cell: the whole cell (what a client makes it do) beside the
    controller's event log."""
    eye = None
    if eye_cell is not None:
        eye = rrb.EyeControls3D(position=eye_cell[0], look_target=eye_cell[1], eye_up=(0, 0, 1))
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial3DView(origin="/world", name="cell", eye_controls=eye),
            rrb.TextLogView(origin="/log", name="event log"),
            column_shares=[3, 1],
        ),
        rrb.TimePanel(timeline=SIM_TIME, state="expanded"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.BlueprintPanel(state="collapsed"),
    )
