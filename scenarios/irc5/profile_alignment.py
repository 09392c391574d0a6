"""Laser profiles paired with the poses they were read at, by time: each profile's stamp
brought onto the controller's clock (less the clock's offset and the sensor's latency), its
joints interpolated between the EGM samples around that instant (`readings`).

The offset is set while the arm stands (scenarios.irc5.remote_controller): a profile made
standing against the newest position sample. On the twin both clocks stand still while the
arm does, so the offset is exact; on a real controller it is off by the difference of the two
links' delays, which the sensor's latency (from exposure to stamp, a parameter the laser's
calibration identifies) takes up.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from cell.readings import LaserReading
from scenarios.irc5.egm_feedback import Feedback
from scenarios.irc5.line_profiler import Received
from scenarios.irc5.link_errors import LinkError

#: Stamps this close are one instant [s] (a sensor clock kept in Unix time resolves 0.24 us
#: in a float64).
SAME_INSTANT_S = 1.0e-5
#: The widest gap between two position samples a profile's pose is interpolated over [s]
#: (a dozen EGM periods: lost packets; the joints of a straight move at scan speed are
#: straight to a micrometre over it); a profile in a wider gap has no pose and is dropped.
MAX_GAP_S = 0.05


def _offset_at(
    stamp_s: float, offset_s: float | tuple[tuple[float, float], tuple[float, float]]
) -> float:
    if isinstance(offset_s, float):
        return offset_s
    (s0, o0), (s1, o1) = offset_s
    if s1 <= s0:
        return o0
    return o0 + (o1 - o0) * (stamp_s - s0) / (s1 - s0)


def _pose_at(t: float, times: np.ndarray, q: np.ndarray) -> np.ndarray | None:
    """Joints (6,) at the controller's time t [s] between samples at `times` (sorted, one per
    instant), or None."""
    k = int(np.searchsorted(times, t))
    if k == 0 or k == len(times) or times[k] - times[k - 1] > MAX_GAP_S:
        return None
    w = (t - times[k - 1]) / (times[k] - times[k - 1])
    return (1.0 - w) * q[k - 1] + w * q[k]


def readings(
    profiles: Sequence[Received],
    feedback: Sequence[Feedback],
    offset_s: float | tuple[tuple[float, float], tuple[float, float]],
    latency_s: float = 0.0,
    table_m: float | None = None,
) -> list[LaserReading]:
    """Each profile with the joints at its exposure, in the controller's time: its stamp less
    `offset_s` (or, for a clock that drifts, the offset interpolated in the sensor's time
    between two (stamp, offset) pairs measured before and after) and the sensor's
    `latency_s` [s]. A profile at an instant the stream has samples of (a controller standing
    still repeats its time) takes the sample that came nearest to it, each its own encoder
    reading; else the joints are interpolated between the samples around it. Profiles
    outside the samples' span or in a gap wider than MAX_GAP_S are dropped, and so are those
    that repeat the number of the one before (a point laser's reading that several EGM
    packets carried: the first packet's is kept). The table from the samples (or `table_m`
    [m])."""
    if not feedback:
        return []
    profiles = [r for k, r in enumerate(profiles)
                if k == 0 or r.profile.seqno != profiles[k - 1].profile.seqno]  # fmt: skip
    all_times = np.array([s.time_s for s in feedback])
    arrived = np.array([s.received_s for s in feedback])
    times, first = np.unique(all_times, return_index=True)
    q = np.array([feedback[i].q for i in first])
    out = []
    for r in profiles:
        stamp = r.profile.stamp_s
        t = stamp - _offset_at(stamp, offset_s) - latency_s
        same = np.flatnonzero(np.abs(all_times - t) <= SAME_INSTANT_S)
        if len(same):
            sample = feedback[int(same[np.argmin(np.abs(arrived[same] - r.received_s))])]
            pose: np.ndarray | None = sample.q
        else:
            sample = feedback[int(first[min(int(np.searchsorted(times, t)), len(times) - 1)])]
            pose = _pose_at(t, times, q)
        if pose is None:
            continue
        table = sample.table_m if sample.table_m is not None else table_m
        if table is None:
            raise LinkError("the table's position came neither with the EGM samples nor given")
        out.append(LaserReading(r.profile.distances, pose, float(table), float(t)))
    return out
