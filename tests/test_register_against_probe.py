"""A surface match held against the IR probing's pose (scenarios.stages.register_stage): one that
agrees stands; one that lies half a turn away is matched again from the probe's pose, taken
where the scan fits that pose as well, and refused where it does not. The poses are made
here, the agreement bounds (2 deg, 3 mm) are the module's."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from scenarios.offline.localization import Localization
from scenarios.stages.register_stage import against_probe, disagreement
from scenarios.stages.state import LocatedPose

CENTRE = np.array([0.05, 0.02, 0.01])  # the model's centre in its frame [m]


def _pose(heading_deg: float, x_m: float = 0.0) -> np.ndarray:
    a = np.radians(heading_deg)
    T = np.eye(4)
    T[:2, :2] = [[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]
    T[:3, 3] = [0.3 + x_m, -0.1, 0.004]
    return T


def _located(T: np.ndarray, rms_m: float, accepted: bool = True) -> LocatedPose:
    found = Localization(T, SimpleNamespace(rms=rms_m), np.empty((0, 3)), 0)  # type: ignore[arg-type]
    return LocatedPose("surface", T, accepted, "all 2 targets located", localization=found)


def _never(_: np.ndarray) -> LocatedPose:
    raise AssertionError("matched again although the poses agree")


def test_the_disagreement_is_the_heading_and_the_centre_sideways() -> None:
    turn, shift = disagreement(_pose(30.0), _pose(-150.0), CENTRE)
    assert abs(turn - 180.0) < 1e-9
    # The centre turned half a turn about the origin: twice its sideways distance from it.
    assert abs(shift - 2 * np.hypot(*CENTRE[:2])) < 1e-12
    turn, shift = disagreement(_pose(10.0, 0.002), _pose(10.0), CENTRE)
    assert abs(turn) < 1e-9 and abs(shift - 0.002) < 1e-12
    turn, _ = disagreement(_pose(179.0), _pose(-179.0), CENTRE)  # across the wrap
    assert abs(turn - 2.0) < 1e-9


def test_a_match_that_agrees_with_the_probe_stands() -> None:
    pose = _located(_pose(10.0, 0.002), 9e-5)  # 0.5 deg and 2 mm off: within 2 deg, 3 mm
    heard: list[str] = []
    out = against_probe(pose, _pose(10.5), _never, CENTRE, lambda *a: heard.append(a[0]))
    assert out is pose and not heard


def test_a_half_turned_match_gives_way_to_the_probe_s_where_the_scan_fits_both() -> None:
    probe = _pose(10.0)
    heard: list[str] = []
    out = against_probe(
        _located(_pose(190.0), 9.3e-5),
        probe,
        lambda prior: _located(prior, 8.7e-5),
        CENTRE,
        lambda *a: heard.append(a[0]),
    )
    assert heard == ["match_disagrees"]
    assert out.accepted and out.T_table_object is not None
    np.testing.assert_allclose(out.T_table_object, probe, atol=1e-12)
    assert "180.0 deg" in out.reason and "fits the probe's as well" in out.reason


def test_a_half_turned_match_is_refused_where_the_probe_s_pose_fits_worse() -> None:
    first = _located(_pose(190.0), 9.3e-5)
    worse = against_probe(
        first, _pose(10.0), lambda prior: _located(prior, 1.2e-4), CENTRE, lambda *a: None
    )
    assert not worse.accepted and "fits worse" in worse.reason
    refused = against_probe(
        first,
        _pose(10.0),
        lambda prior: _located(prior, 8e-5, accepted=False),
        CENTRE,
        lambda *a: None,
    )
    assert not refused.accepted and "not accepted" in refused.reason
    # A second match that leaves the probe's pose for the first one's is no agreement.
    drifted = against_probe(
        first, _pose(10.0), lambda prior: _located(_pose(190.0), 9e-5), CENTRE, lambda *a: None
    )
    assert not drifted.accepted
