"""The controller client (scenarios.irc5) against `twincell serve` in another process: the
moves, the table and the tool changer over RWS, the encoders over EGM, the laser over its
profile stream; nothing commanded on a stale stream; and a scan through the network that
sees the object where a scan in the job's own process sees it, both measured against the
truth of the same real cell."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import igl
import numpy as np
import pytest
from abb_robot_client.rws import RWS
from bench_support.served_twin import free_port
from rrd_reader import read_rrd

from cell import LaserConfig, nominal_T_base_table
from cell.irb2400_arm import irb2400
from models.robot import RACK_POS
from scenarios.irc5.egm_feedback import EgmFeedback, Feedback
from scenarios.irc5.line_profiler import ProfileBuffer, ProfileStream
from scenarios.irc5.link_errors import LinkError
from scenarios.irc5.remote_controller import RemoteController
from scenarios.irc5.rws_link import RwsLink
from scenarios.offline.calibration_artifact import DEFAULT_ARTIFACT
from scenarios.offline.laser_latency import LatencyEstimate, latency_alone

SPEED = 20.0
_STILL = Feedback(0.0, 0.0, 0, np.zeros(6), None, False, True)


@dataclass
class Served:
    process: subprocess.Popen[bytes]
    rws: int
    egm: int
    profiles: int

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.rws}"


def serve(
    out: Path,
    job: str = "skull",
    seed: int = 0,
    speed: float = SPEED,
    extra: tuple[str, ...] = (),
) -> Served:
    """`twincell serve JOB` for `seed` in a process of its own, its time `speed` times the
    wall's, with the `extra` options, its lines to serve.log in `out`."""
    rws, egm = free_port(socket.SOCK_STREAM), free_port(socket.SOCK_DGRAM)
    profiles = free_port(socket.SOCK_STREAM)
    command = [
        sys.executable, "-m", "scenarios.cli", "serve", job, "--seed", str(seed),
        "--speed", str(speed), "--rws", f"127.0.0.1:{rws}", "--egm-port", str(egm),
        "--profiles", str(profiles), "--out", str(out), "--quiet", *extra,
    ]  # fmt: skip
    log = out / "serve.log"
    with log.open("w") as sink:
        process = subprocess.Popen(command, stdout=sink, stderr=subprocess.STDOUT)
    deadline = time.monotonic() + 120.0
    while "serving http" not in log.read_text():
        if process.poll() is not None or time.monotonic() > deadline:
            process.kill()
            pytest.fail(f"twincell serve did not start: {log.read_text()[-2000:]}")
        time.sleep(0.1)
    return Served(process, rws, egm, profiles)


def stop(served: Served) -> None:
    served.process.send_signal(signal.SIGTERM)
    served.process.wait(timeout=30)


@pytest.fixture(scope="module")
def served(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Served]:
    """The skull job's real cell (seed 0) served in a process of its own."""
    twin = serve(tmp_path_factory.mktemp("serve"))
    yield twin
    stop(twin)


def _client(served: Served, timeout_s: float = 5.0) -> RemoteController:
    robot = irb2400()
    link = RwsLink(served.url, "Default User", "robotics", timeout_s)
    feedback = EgmFeedback(served.egm)
    profiles = ProfileBuffer(ProfileStream("127.0.0.1", served.profiles))
    try:
        return RemoteController(
            link, feedback, profiles, robot, robot.kinematics(), RACK_POS, LaserConfig()
        )
    except BaseException:
        profiles.close()
        feedback.close()
        link.close()
        raise


def test_moves_tool_and_laser_over_the_network(served: Served) -> None:
    client = _client(served)
    try:
        q = client.q_home + np.array([0.1, -0.05, 0.05, 0.0, 0.1, 0.0])
        client.move_joints(q)
        # the twin's encoders, as EGM brought them, against the joints commanded: within the
        # servo's settling and the encoders' noise (a few hundredths of a milliradian)
        assert np.max(np.abs(client.read_joints() - q)) < 2e-4
        readings = np.array([client.read_joints() for _ in range(5)])
        assert np.ptp(readings, axis=0).max() > 0.0  # each read a new sample
        client.move_table(0.1)
        assert client.table_position() == pytest.approx(0.1, abs=1e-3)
        client.change_tool("laser")
        assert client.tool_in_hand == "laser"
        # the controller's own word, read by a client of its own
        rws = RWS(served.url)
        assert rws.get_analog_io("aiToolNumber") == 1 + client.tools.index("laser")
        rws.close()
        before = client.time_s
        reading = client.read_laser()
        assert reading.distances.shape == (len(client.laser_directions_tcp),)
        assert reading.time_s == pytest.approx(before, abs=1e-3)  # the arm stood: same instant
        client.move_joints(client.q_home)
        assert client.moves >= 8
    finally:
        client.close()


def test_nothing_moves_on_a_stale_stream(served: Served) -> None:
    client = _client(served, timeout_s=1.0)
    try:
        q_before = client.read_joints()
        os.kill(served.process.pid, signal.SIGSTOP)  # the controller stops answering
        try:
            time.sleep(0.3)
            with pytest.raises(LinkError, match="stale"):
                client.move_joints(client.q_home + 0.05)
        finally:
            os.kill(served.process.pid, signal.SIGCONT)  # and comes back
        time.sleep(0.3)
        # nothing was commanded: the arm stands where it stood
        assert np.max(np.abs(client.read_joints() - q_before)) < 2e-4
        client.move_joints(client.q_home)
        assert np.max(np.abs(client.read_joints() - client.q_home)) < 2e-4
    finally:
        client.close()


def test_a_controller_that_stops_answering_mid_move(served: Served) -> None:
    """The controller stops answering while a move runs: the client stops the job there
    (LinkError, saying what it waited for) instead of commanding on; the controller comes
    back, ends its move, and a new session drives it on."""
    import threading

    client = _client(served, timeout_s=1.0)
    pid = served.process.pid
    try:

        def stop_once_it_moves() -> None:  # the controller's own word: RAPID runs
            while not (client.feedback.latest() or _STILL).rapid_running:
                time.sleep(0.001)
            os.kill(pid, signal.SIGSTOP)

        watcher = threading.Thread(target=stop_once_it_moves)
        watcher.start()
        try:
            with pytest.raises(LinkError, match=r"did not answer|stale|no EGM feedback"):
                # a slow move: seconds of the controller's time
                client.move_joints(client.q_home + np.array([0.6, 0, 0, 0, 0, 0]), speed=0.05)
        finally:
            watcher.join()
            os.kill(pid, signal.SIGCONT)
    finally:
        client.close()
    again = _client(served)
    try:
        again.move_joints(again.q_home)
        assert np.max(np.abs(again.read_joints() - again.q_home)) < 2e-4
    finally:
        again.close()


def test_motors_off_or_manual_mode_are_refused_with_what_to_change(
    served: Served, short_skull_run: Path, tmp_path: Path
) -> None:
    from scenarios.irc5.link_errors import ControllerRefusalError
    from scenarios.jobs.serve import serve_job
    from scenarios.twin.server import ServeOptions

    rws = RWS(served.url)
    rws.set_controller_state("motoroff")
    try:
        with pytest.raises(ControllerRefusalError, match=r"motors are off .*switch them on"):
            _client(served)
    finally:
        rws.set_controller_state("motoron")
        rws.close()
    manual = serve_job(str(short_skull_run), ServeOptions(port=0, opmode="MANR"), out=tmp_path)
    link = RwsLink(manual.url, "Default User", "robotics")
    try:
        with pytest.raises(ControllerRefusalError, match=r"MANR mode: .* AUTO"):
            link.ready()
    finally:
        link.close()
        manual.close()


def _identified_latency(served: Served) -> LatencyEstimate:
    """The laser's latency as the calibration identifies it (scenarios.offline.laser_latency),
    on the middle sphere at the calibration's last table position, the arm nominal."""
    client = _client(served)
    try:
        found = latency_alone(client, DEFAULT_ARTIFACT, -0.05)
    finally:
        client.close()
    print(f"latency {found.latency_s * 1e3:.3f} +- {found.sigma_s * 1e3:.3f} ms")
    return found


@pytest.mark.slow
def test_a_scan_through_a_poor_network_sees_the_object_as_one_in_process(
    tmp_path: Path,
) -> None:
    """The first pass of the skull job's scan through a network that answers RWS 20 to 30 ms
    late and loses a fifth of the EGM packets, with a laser whose clock runs 200 ppm fast and
    that stamps each profile 20 ms after its exposure: the latency is identified on a sphere
    to 1 ms (true: the twin's option, which the client never sees), each profile still finds
    its pose (interpolated over the lost packets, the clock's offset set again while the arm
    stands before the pass, less the latency), and the scan sees the skull as the same pass
    in process does. Paired without the latency, each line would sit 20 ms of travel along
    the pass (5 mm at 0.25 m/s) off."""
    twin = serve(
        tmp_path, extra=("--rws-latency", "20", "--rws-jitter", "10", "--egm-loss", "0.2",
                         "--laser-drift", "200", "--laser-latency", "20"),
    )  # fmt: skip
    try:
        found = _identified_latency(twin)
        assert found.latency_s == pytest.approx(0.020, abs=1e-3)
        assert found.sigma_s < 5e-4  # its own uncertainty within half the tolerance
        _compare_first_pass(twin, min_share=0.9, latency_s=found.latency_s)
    finally:
        stop(twin)


@pytest.mark.slow
def test_a_scan_over_the_network_sees_the_object_as_one_in_process(served: Served) -> None:
    """The first pass of the skull job's scan, run through the network and in this process on
    the same real cell (seed 0): each scan's points, rebuilt with the nominal arm, against the
    real skull at its true pose. A reading paired with the wrong pose (a profile late or early
    by a control period moves its line 0.4 mm along the pass at this speed) shows as a spread
    the in-process scan does not have. The laser has no latency, and none is found (1 ms)."""
    found = _identified_latency(served)
    assert found.latency_s == pytest.approx(0.0, abs=1e-3)
    _compare_first_pass(served, min_share=0.97)


def _compare_first_pass(served: Served, min_share: float, latency_s: float = 0.0) -> None:
    """The first scan pass through `served` (its lines paired with the encoders `latency_s`
    [s] before their stamps) against the same pass in process: at least `min_share` of the
    points on the skull, the same median distance to its true surface (20 um) and the same
    spread (50 um)."""
    from scenarios.configuration.config_files import load_config
    from scenarios.configuration.job_config import JobConfig
    from scenarios.jobs.job_plan import plan_job
    from scenarios.jobs.serve import cell_of_job
    from scenarios.offline.scan_passes import execute_scan

    config = load_config("skull", {"seed": 0})
    assert isinstance(config, JobConfig)
    plan = plan_job(config, lambda _m: None)
    assert plan.scan_plan is not None
    passes = plan.scan_plan.passes[:1]
    scan_config = plan.settings.localization.scan
    job = cell_of_job("skull", seed=0)
    remote = _client(served)
    remote.set_laser_latency(latency_s)
    try:
        ours = execute_scan(remote, passes, scan_config)
        table_m = remote.table_position()
    finally:
        remote.close()
    theirs = execute_scan(job.controller, passes, scan_config)
    V = job.evaluator.true_points_base(plan.real.mesh.vertices)
    F = np.asarray(plan.real.mesh.faces)

    def distances(points_table: np.ndarray) -> np.ndarray:
        T = nominal_T_base_table(table_m)
        p = points_table @ T[:3, :3].T + T[:3, 3]
        d2, _i, _c = igl.point_mesh_squared_distance(p, V, F)
        return np.sqrt(d2)

    d_net, d_in = distances(ours.points_table), distances(theirs.points_table)
    # the points on the skull (the rest fell on the table around it)
    on_net, on_in = d_net[d_net < 3e-3], d_in[d_in < 3e-3]
    assert len(on_in) > 5000
    assert min_share * len(on_in) <= len(on_net) <= 1.03 * len(on_in)
    # the same surface seen: medians within 20 um, the spread within 50 um (the arm's error,
    # the same on both, is most of either)
    assert abs(np.median(on_net) - np.median(on_in)) < 2e-5
    assert abs(np.percentile(on_net, 95) - np.percentile(on_in, 95)) < 5e-5
    print(
        f"on the skull: network {len(on_net)} points, median {np.median(on_net) * 1e3:.4f} mm, "
        f"q95 {np.percentile(on_net, 95) * 1e3:.4f} mm; in process {len(on_in)}, median "
        f"{np.median(on_in) * 1e3:.4f} mm, q95 {np.percentile(on_in, 95) * 1e3:.4f} mm"
    )


@pytest.mark.slow
def test_a_job_across_the_network_as_in_process(short_skull_run: Path, tmp_path: Path) -> None:
    """The short skull job (its own seed) run against its real cell served in another process
    ends within its goals (complete; or at risk, where its error budget, drawn anew, comes
    within reach of the goal: a loaded machine's twin, lagging the wall clock, has ended it
    so), the twin measuring every target it touched and the exported program, and its
    targets' RMS error is the same job's in process to 0.1 mm. Single targets
    differ more: the twin reads its encoders every control period and its laser at its own
    instants, so its noise is another draw than the job's in process, and the registration's
    share of a target moves with the draw by up to its predicted TRE (up to 0.17 mm seen on
    ten seeds, where two runs of the same cell in process, `cell.noise.draw` 0 and 1, moved
    one by up to 0.16 mm; bench/bench_network_job.py prints both seed by seed). The twin's
    laser stamps each profile 8 ms after its exposure: the job's calibration finds that to
    1 ms, or its scan's lines would sit 2 mm along their passes off. The run is recorded:
    the arm posed by the controller's stream through the whole run, the laser's rays only
    while it scans. The cell's commissioning is the in-process run's record of the same
    cell (`--commissioning`): the job reads no tool at the beam for it and keeps that
    record."""
    from scenarios.jobs.network_job import ControllerAddress
    from scenarios.jobs.runner import RunOptions, run_job
    from scenarios.results.run import RunResult

    theirs = json.loads((short_skull_run / "results.json").read_text())
    commissioned = short_skull_run / "commissioning.json"
    twin = serve(tmp_path, str(short_skull_run), theirs["seed"], SPEED, ("--laser-latency", "8"))
    address = ControllerAddress(twin.url, twin.egm, ("127.0.0.1", twin.profiles))
    try:
        folder, ours = run_job(
            short_skull_run / "config.yaml",
            out=tmp_path / "runs",
            options=RunOptions(rrd=True, controller=address, commissioning=commissioned),
        )
    finally:
        stop(twin)
    assert isinstance(ours, RunResult)
    assert theirs["status"] == "complete"
    assert ours.status in ("complete", "at_risk"), ours.reason
    assert all(check.met for check in ours.checks.values())
    found = ours.calibration.summary
    assert found is not None and found.laser_latency_s is not None
    assert found.laser_latency_s == pytest.approx(0.008, abs=1e-3)
    assert theirs["calibration"]["laser_latency_s"] is None  # in process: nothing to identify
    errors = {t["name"]: t["error_m"] for t in theirs["targets"]}
    touched = {t.name: t.error_m for t in ours.methods[0].targets}
    assert touched.keys() == errors.keys()
    assert all(0.0 < e < 1e-3 for e in touched.values())  # measured, within the max goal
    assert ours.target_error_rms_m == pytest.approx(theirs["target_error_rms_m"], abs=1e-4)
    exported = ours.exported_program
    assert exported is not None and exported.target_error_rms_m is not None  # the twin's
    assert exported.target_error_rms_m < 5e-4
    assert ours.cell_time_s is not None
    _recorded_as_it_ran(folder / "run.rrd", ours.cell_time_s)
    kept = json.loads((folder / "commissioning.json").read_text())
    assert kept == json.loads(commissioned.read_text())
    assert ours.tool_checks and all(check.referenced for check in ours.tool_checks)


def _recorded_as_it_ran(rrd: Path, cell_time_s: float) -> None:
    """The arm's last link drawn from the start to the end of the run at the recording's
    frame rate or more while it moved; every laser ray while the laser scans (the
    calibration's views and sweeps, the scan, the verification), none while it executes."""
    entities = read_rrd(rrd)
    times = [t for t, _, _ in entities["/world/cell/arm/link6"].rows if t is not None]
    assert min(times) < 1.0 and max(times) > 0.95 * cell_time_s
    assert len(times) > 10 * cell_time_s  # 30 Hz of the controller's time while moving
    phases = sorted(
        (t, c["TextLog:text"][0].split(" == ")[0].removeprefix("== "))
        for t, _, c in entities["/log"].rows
        if t is not None and c["TextLog:text"][0].startswith("== ")
    )
    rays = [t for t, _, _ in entities["/world/laser/rays"].rows if t is not None]
    assert len(rays) > 500
    during = {max((p for p in phases if p[0] <= t), default=(0.0, "none"))[1] for t in rays}
    assert during <= {"calibrate", "scan", "verify"}, during
