"""The targets in the recording, logged when they are evaluated (after the touches).

Small markers: corrected (green, where the corrected program aimed), achieved (magenta,
where the tool tip really went) and true (black, the target on the real object). The errors,
a few tenths of a millimetre, would vanish inside any marker: each is drawn as a line from
the true point towards the achieved one, magnified by a stated factor and labelled with the
target's name and its true length; around each corrected target, the registration's
predicted TRE as an ellipsoid (one standard deviation, magnified alike). Per target bar
charts give the errors and the predicted TRE in mm.
"""

from __future__ import annotations

import numpy as np
import rerun as rr
from scipy.spatial.transform import Rotation

from scenarios.realcell.evaluation import TargetEvaluation
from scenarios.realcell.recording.stream import Stream

#: A target's label stands this far out from it, away from the object's centre [m].
LABEL_OUT_M = 0.03
#: Magnifications offered; the largest that keeps the longest line within LINE_M is used.
FACTORS = (1, 2, 5, 10, 20, 50, 100, 200)
LINE_M = 0.015


def magnification(errors_m: np.ndarray) -> int:
    """The largest factor of FACTORS that draws the largest error within LINE_M."""
    worst = float(np.max(errors_m, initial=0.0))
    fits = [f for f in FACTORS if f * worst <= LINE_M]
    return fits[-1] if fits else 1


def ellipsoids(covariances: np.ndarray, factor: float) -> tuple[np.ndarray, np.ndarray]:
    """Half sizes (K, 3) [m] and quaternions xyzw (K, 4) of the one-sigma ellipsoids of
    covariances (K, 3, 3), magnified by `factor`."""
    values, vectors = np.linalg.eigh(covariances)
    vectors[np.linalg.det(vectors) < 0, :, 2] *= -1.0
    return factor * np.sqrt(np.clip(values, 0.0, None)), Rotation.from_matrix(vectors).as_quat()


def log_targets(
    stream: Stream,
    time_s: float,
    corrected_base: np.ndarray,
    evaluated: tuple[TargetEvaluation, ...],
    covariances_base: np.ndarray | None,
    centre_base: np.ndarray,
) -> int:
    """The targets at `time_s`: corrected (K, 3) [m] in the base frame, their evaluation,
    the predicted TRE covariances (K, 3, 3) [m^2] in the base frame (None: no surface
    match); labels stand out from the object's centre `centre_base` (3,). Returns the
    magnification of the error lines."""
    stream.at(sim_time=time_s)
    stream.log(
        "world/targets/corrected", rr.Points3D(corrected_base, radii=0.0006, colors=[[40, 200, 60]])
    )
    if not evaluated:
        return 1
    true = np.array([t.p_true_base for t in evaluated])
    achieved = np.array([t.p_achieved_base for t in evaluated])
    errors = np.array([t.error_m for t in evaluated])
    factor = magnification(errors)
    stream.log(
        "world/targets/achieved", rr.Points3D(achieved, radii=0.0005, colors=[[230, 0, 230]])
    )
    stream.log("world/targets/true", rr.Points3D(true, radii=0.0005, colors=[[20, 20, 20]]))
    stream.log(
        f"world/targets/errors_x{factor}",
        rr.Arrows3D(
            origins=true, vectors=factor * (achieved - true), colors=[[230, 0, 230]], radii=0.0003
        ),
    )
    out = true - centre_base
    out /= np.maximum(np.linalg.norm(out, axis=1, keepdims=True), 1e-9)
    anchors = true + LABEL_OUT_M * out
    stream.log(
        "world/targets/labels",
        rr.Points3D(
            anchors,
            radii=0.0002,
            colors=[[230, 0, 230]],
            labels=[f"{t.name} {t.error_m * 1e3:.2f} mm" for t in evaluated],
        ),
        rr.LineStrips3D(np.stack([true, anchors], axis=1), colors=[[200, 200, 200]], radii=0.0001),
    )
    text = ", ".join(f"{t.name} {t.error_m * 1e3:.3f}" for t in evaluated)
    stream.log(
        "log",
        rr.TextLog(
            f"targets: error lines (true to achieved) and predicted-TRE ellipsoids drawn "
            f"x{factor}; errors [mm]: {text}",
            level="INFO",
        ),
    )
    stream.log("plots/targets/error_mm", rr.BarChart(errors * 1e3, color=[230, 0, 230]))
    if covariances_base is not None:
        half, quat = ellipsoids(covariances_base, factor)
        stream.log(
            "world/targets/predicted_tre",
            rr.Ellipsoids3D(
                centers=corrected_base,
                half_sizes=half,
                quaternions=quat,
                colors=[[60, 140, 255]],
                fill_mode="majorwireframe",
                line_radii=0.0002,
            ),
        )
        tre = np.sqrt(np.trace(covariances_base, axis1=1, axis2=2))
        stream.log("plots/targets/predicted_tre_mm", rr.BarChart(tre * 1e3, color=[60, 140, 255]))
    return factor
