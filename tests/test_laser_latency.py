"""The laser's latency identification (scenarios.offline.laser_latency) on sweeps made here:
each line's ranges cast analytically at the laser's pose when it was exposed, its joints
those of its stamp, a known latency later; and the twin's laser stream stamping profiles made
while the arm moves that latency after their exposure (scenarios.twin.sensor_streams)."""

from __future__ import annotations

import numpy as np
import pytest

from cell import LaserConfig, LaserReading, nominal_T_base_table
from cell.irb2400_arm import irb2400
from cell.profile_frames import Profile
from models.robot import LASER
from scenarios.offline.calibration_artifact import DEFAULT_ARTIFACT
from scenarios.offline.calibration_measurement import view_pose
from scenarios.offline.cell_model import CellModel
from scenarios.offline.laser_latency import LatencySweeps, identify_latency
from scenarios.twin.sensor_streams import LaserStream, SensorStreams

RADIUS = DEFAULT_ARTIFACT.radius_m


def _ranges(origin: np.ndarray, rays: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """(n,) distances along unit `rays` (n, 3) from `origin` to the sphere, NaN on a miss."""
    oc = origin - centre
    b = rays @ oc
    disc = b**2 - (oc @ oc - RADIUS**2)
    d = -b - np.sqrt(np.where(disc >= 0.0, disc, np.nan))
    return np.where(d > 0.0, d, np.nan)


def _sweeps(latency_s: float, noise_m: float, seed: int = 0) -> tuple[LatencySweeps, CellModel]:
    """Four sweeps over the middle sphere (0.1 and 0.25 m/s, forth and back), a line every
    10 ms: each line's ranges at the exposure, its joints and time `latency_s` later."""
    rng = np.random.default_rng(seed)
    robot = irb2400()
    kin = robot.kinematics()
    T_table = nominal_T_base_table(-0.05)
    centre = T_table[:3, :3] @ DEFAULT_ARTIFACT.centres_table[1] + T_table[:3, 3]
    above = view_pose(centre, 0.0, 0.0, 0.0, 0.22)
    along = above[:3, 1]
    dirs = LaserConfig().directions_tcp()
    q = robot.q_home
    sweeps = []
    for speed in (0.1, 0.25):
        for sign in (1.0, -1.0):
            lines = []
            for t in np.arange(0.0, 0.13 / speed, 0.01):
                s = sign * (-0.065 + speed * t)  # from one end, at constant speed

                def pose(s: float) -> np.ndarray:
                    T = above.copy()
                    T[:3, 3] = above[:3, 3] + s * along
                    return T

                exposed, stamped = pose(s), pose(s + sign * speed * latency_s)
                d = _ranges(exposed[:3, 3], dirs @ exposed[:3, :3].T, centre)
                d = d + rng.normal(0.0, noise_m, len(d))
                q = kin.solve(stamped, q, LASER.T_tool_tcp)
                lines.append(LaserReading(d, q, -0.05, float(t + latency_s)))
            sweeps.append(tuple(lines))
    return LatencySweeps(1, centre, tuple(sweeps)), CellModel.nominal(kin)


@pytest.mark.parametrize("latency_s", [0.0, 0.008, 0.020])
def test_a_known_latency_is_found_to_a_tenth_of_a_millisecond(latency_s: float) -> None:
    sweeps, model = _sweeps(latency_s, noise_m=5e-5)
    found = identify_latency(sweeps, model, LaserConfig().directions_tcp(), RADIUS, 0.0)
    assert found.latency_s == pytest.approx(latency_s, abs=1e-4)
    assert 0.0 < found.sigma_s < 2e-4
    assert found.sweeps == 4
    # the ranges' noise along the sphere's normal: at most their own sigma (grazing rays less)
    assert 1e-5 < found.residual_rms_m <= 5.5e-5


def test_the_latency_found_adds_to_the_one_the_lines_were_paired_with() -> None:
    """Lines paired with 5 ms already: 20 ms more is found, 25 ms in all."""
    sweeps, model = _sweeps(0.020, noise_m=5e-5)
    found = identify_latency(sweeps, model, LaserConfig().directions_tcp(), RADIUS, 0.005)
    assert found.latency_s == pytest.approx(0.025, abs=1e-4)


class _Cell:
    tool_in_hand = "laser"

    def __init__(self) -> None:
        self.time_s = 0.0

    def read_laser(self) -> LaserReading:
        return LaserReading(np.zeros(3), np.zeros(6), 0.0, self.time_s)


class _Profiles:
    def __init__(self) -> None:
        self.sent: list[Profile] = []

    def send(self, profile: Profile) -> None:
        self.sent.append(profile)


class _Snap:
    def __init__(self, time_s: float) -> None:
        self.time_s = time_s


def test_the_twin_stamps_profiles_made_in_motion_its_latency_late() -> None:
    """Moving: stamp = exposure + latency + the clock's offset; standing (the twin's time
    still): stamp = exposure + offset, so an offset set standing cannot take the latency up."""
    cell, profiles = _Cell(), _Profiles()
    laser = LaserStream(period_s=0.01, clock_offset_s=100.0, latency_s=0.02)
    streams = SensorStreams(None, profiles, laser)  # type: ignore[arg-type]
    for k in range(5):
        cell.time_s = 1.0 + 0.01 * k
        streams.publish(cell, _Snap(cell.time_s), True, True, moving=True)  # type: ignore[arg-type]
    moving = [p.stamp_s - 100.0 for p in profiles.sent]
    assert moving == pytest.approx([1.02 + 0.01 * k for k in range(5)], abs=1e-9)
    profiles.sent.clear()
    for _ in range(40):  # standing: a profile every period of the wall clock's ticks
        streams.publish(cell, _Snap(cell.time_s), True, False, moving=False)  # type: ignore[arg-type]
    assert profiles.sent
    assert all(p.stamp_s - 100.0 == pytest.approx(cell.time_s) for p in profiles.sent)


def test_a_latency_out_of_range_is_refused() -> None:
    with pytest.raises(ValueError, match="latency"):
        LaserStream(latency_s=-0.001)


def test_a_data_sheet_latency_is_given_to_the_client_and_not_identified() -> None:
    """`calibration.latency: 0.008`: the client pairs the lines 8 ms back from the start and
    the calibration sweeps nothing; by default it starts at 0 and the calibration identifies."""
    from scenarios.configuration.config_files import load_config
    from scenarios.configuration.job_config import JobConfig
    from scenarios.jobs.network_job import client_settings
    from scenarios.scenario_errors import ScenarioError

    given = load_config("skull", {"calibration.latency": 0.008})
    assert isinstance(given, JobConfig)
    assert client_settings(given).laser_latency_s == 0.008
    default = load_config("skull", {})
    assert isinstance(default, JobConfig)
    assert default.calibration.latency == "identify"
    assert client_settings(default).laser_latency_s == 0.0
    with pytest.raises(ScenarioError, match="identify"):
        load_config("skull", {"calibration.latency": "auto"})


def test_a_controller_that_pairs_lines_by_their_own_instant_refuses_a_latency() -> None:
    """In process each laser line comes with the encoders of its instant: no latency to
    identify (the calibration sweeps nothing) and none to set."""
    from cell.cell_errors import CellConfigError
    from cell.sim import CellConfig, make_cell

    controller, _truth = make_cell(CellConfig())
    assert controller.laser_latency_s is None
    with pytest.raises(CellConfigError, match="its own instant"):
        controller.set_laser_latency(0.008)
