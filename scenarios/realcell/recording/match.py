"""The registration in the recording.

On `sim_time`, at the moment of the match: the virtual model moves from its nominal place to
the registered pose (one mesh, its pose a transform), and the scan is drawn coloured by its
signed distance to the registered model, with a colour scale in mm.

On the `icp` timeline, with the cell held as it was at that moment: step 0, the search's
initial states as a cloud of candidate poses (where each would put the model's centre, a
short line along the model's first axis); step 1, the minima the ranking refined them to,
coloured by cost, the best one ringed; then the best one's refinement, iteration by
iteration, with its RMS.
"""

from __future__ import annotations

import io
from dataclasses import dataclass

import matplotlib
import numpy as np
import rerun as rr
from matplotlib.figure import Figure

from models.model import ObjectModel
from registration import MatchResult, invert
from registration.result import SearchTrace
from scenarios.outputs.residuals import (
    COLOUR_MAP,
    colour_scale,
    residual_colours,
    signed_residuals,
)
from scenarios.realcell.recording.stream import Stream, pose


def colour_bar(
    scale_m: float, label: str = "scan point to registered model [mm] (inside < 0 < outside)"
) -> np.ndarray:
    """An image (H, W, 3) of the colour scale, labelled in mm."""
    fig = Figure(figsize=(5.0, 0.8), dpi=100)
    ax = fig.subplots()
    gradient = np.linspace(-1.0, 1.0, 256)[None, :]
    s = scale_m * 1e3
    ax.imshow(gradient, aspect="auto", cmap=COLOUR_MAP, extent=(-s, s, 0, 1))
    ax.set_yticks([])
    ax.set_xlabel(label, fontsize=9)
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="raw", dpi=100)
    w, h = fig.canvas.get_width_height()
    return np.frombuffer(buffer.getvalue(), dtype=np.uint8).reshape(h, w, 4)[:, :, :3]


def log_registered(
    stream: Stream,
    time_s: float,
    result: MatchResult,
    virtual: ObjectModel,
    points_table: np.ndarray,
    table: str,
) -> np.ndarray:
    """At `time_s`: the model (entity `<table>/model`) at the registered pose; the scan
    points (N, 3, table frame) coloured by residual (`<table>/scan/registered`) in place of
    the passes; the colour bar. Returns the residuals (N,) [m] (inf: off the model)."""
    T_table_object = invert(result.T_model_data)
    p_model = points_table @ result.T_model_data[:3, :3].T + result.T_model_data[:3, 3]
    residuals, _ = signed_residuals(virtual, p_model)
    scale = colour_scale(result.sigma)
    stream.at(sim_time=time_s)
    stream.log(
        "plots/icp/rms_per_iteration_mm",
        rr.BarChart(np.asarray(result.history) * 1e3, color=[80, 160, 255]),
    )
    stream.log(f"{table}/model", pose(T_table_object))
    stream.log(f"{table}/scan/passes", rr.Clear(recursive=True))
    stream.log(
        f"{table}/scan/registered",
        rr.Points3D(points_table, colors=residual_colours(residuals, scale), radii=0.0005),
    )
    stream.log("legend/residual", rr.Image(colour_bar(scale)))
    return residuals


@dataclass(frozen=True, eq=False)
class _Marker:
    """What marks a candidate pose of the model: its centre p_centre (3,) and a point p_tip
    (3,) a quarter of its largest extent along its first principal axis [m, model frame]."""

    p_centre: np.ndarray
    p_tip: np.ndarray

    @staticmethod
    def of(virtual: ObjectModel) -> _Marker:
        vertices = virtual.mesh.vertices
        centre = vertices.mean(axis=0)
        axis = np.linalg.svd(vertices - centre, full_matrices=False)[2][0]
        reach = 0.25 * float(np.ptp(vertices, axis=0).max())
        return _Marker(centre, centre + reach * axis)

    def where(self, T_model_data: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The centre and the tip (K, 3) [m, table frame] of the model at the poses
        T_model_data (K, 4, 4)."""
        inv = np.linalg.inv(T_model_data)  # (K, 4, 4): model into table
        c = inv[:, :3, :3] @ self.p_centre + inv[:, :3, 3]
        return c, inv[:, :3, :3] @ self.p_tip + inv[:, :3, 3]


def _shades(costs: np.ndarray) -> np.ndarray:
    """Colours (K, 4) uint8 by rank of cost: yellow the lowest, purple the highest."""
    rank = np.argsort(np.argsort(costs)) / max(len(costs) - 1, 1)
    return (matplotlib.colormaps["viridis"](1.0 - rank) * 255).astype(np.uint8)


def log_icp(
    stream: Stream,
    result: MatchResult,
    virtual: ObjectModel,
    points_used: np.ndarray,
    table: str,
) -> None:
    """The search and the refinement on the `icp` timeline (see the module's docstring)."""
    stream.at(icp=0)
    stream.log(
        f"{table}/icp/scan",
        rr.Points3D(points_used, colors=[[250, 200, 60]], radii=0.0005),
    )
    search = result.search
    if search is not None and len(search.starts):
        _log_search(stream, search, _Marker.of(virtual), table)
    _log_refinement(stream, result, table)


def _log_search(stream: Stream, search: SearchTrace, marker: _Marker, table: str) -> None:
    """Step 0: the search's initial states, coloured by their score; step 1: the minima the
    ranking refined them to, the best one ringed."""
    c, _ = marker.where(search.starts)
    stream.log(
        f"{table}/icp/starts",
        rr.Points3D(c, colors=_shades(search.start_costs), radii=0.0008),
    )
    stream.log(f"{table}/model", pose(invert(search.starts[np.argmin(search.start_costs)])))
    stream.log(
        "log",
        rr.TextLog(
            f"search: {len(c)} initial states, where each puts the model's centre "
            "(yellow: best scored, purple: worst)",
            level="INFO",
        ),
    )
    stream.at(icp=1)
    m, tip = marker.where(search.minima)
    stream.log(f"{table}/icp/starts", rr.Clear(recursive=False))
    stream.log(
        f"{table}/icp/minima",
        rr.Points3D(m, colors=_shades(search.minima_costs), radii=0.0015),
        rr.LineStrips3D(np.stack([m, tip], axis=1), colors=_shades(search.minima_costs),
                        radii=0.0003),
    )  # fmt: skip
    best, _ = marker.where(search.best[None])
    stream.log(
        f"{table}/icp/best",
        rr.Points3D(best, colors=[[255, 40, 40]], radii=0.004, labels=["best minimum"]),
    )
    stream.log(f"{table}/model", pose(invert(search.best)))
    stream.log(
        "log",
        rr.TextLog(
            f"coarse ICP: {len(m)} minima (a line along the model's first axis each); "
            "the best one (red) refined next",
            level="INFO",
        ),
    )


def _log_refinement(stream: Stream, result: MatchResult, table: str) -> None:
    """From step 2: the best minimum's refinement, iteration by iteration, with its RMS;
    then the registered pose and the verdict."""
    first = 2
    history = np.asarray(result.history) * 1e3
    stream.at(icp=first)
    stream.log("plots/icp/rms_per_iteration_mm", rr.BarChart(history, color=[80, 160, 255]))
    for k, (T_model_data, rms) in enumerate(zip(result.trajectory, result.history, strict=False)):
        stream.at(icp=first + k)
        stream.log(f"{table}/model", pose(invert(T_model_data)))
        stream.log("plots/icp/rms_mm", rr.Scalars(float(rms) * 1e3))
    stream.at(icp=first + len(result.trajectory))
    stream.log(f"{table}/model", pose(invert(result.T_model_data)))
    stream.log(
        "log",
        rr.TextLog(
            f"refined in {result.iterations} iterations to rms {result.rms * 1e3:.3f} mm: "
            f"{result.verdict} ({result.reason})",
            level="INFO" if result.verdict == "accepted" else "WARN",
        ),
    )
    stream.static("plots/icp/rms_mm", rr.SeriesLines(names="ICP rms [mm]"), rr.SeriesPoints())
