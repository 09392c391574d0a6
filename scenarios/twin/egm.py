"""Externally Guided Motion (EGM), as an IRC5 streams it: every 4 ms an `EgmRobot` message
(the joints measured and commanded [deg], the flange pose in the base frame [mm,
quaternion], the table as external axis A [mm], the controller's time, the motors' and
RAPID's states, and in `RAPIDfromRobot.dnum` what the helper module TcHelper's
DataToSensor sends: scenarios.twin.sensor_streams) goes by UDP to the client's port, and the
`EgmSensor` messages the client sends back from there are references the arm follows:
joints [deg] (`EGMRunJoint`), or a pose of tool0 in the base frame [mm, w x y z]
(`EGMRunPose` with tool0 and wobj0), solved on the nominal arm.

The twin's EGM session stands open while it serves. Its feedback streams as a real
controller's position stream does (`EGMActJoint ... \\StreamStart`), while programs run and
while the arm stands. As a program's `EGMRunJoint` would, the arm follows fresh references
when the motors are on and no RAPID program runs, and holds otherwise. The servo follows
within the joints' speed limits; what the drive loop adds to that is the servo's own lag.
"""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from cell.cell_errors import CellError
from registration.rigid import R_to_quat_wxyz, make_T, quat_wxyz_to_R
from scenarios.twin.egm_proto import EgmHeader, EgmRobot, EgmSensor
from scenarios.twin.snapshot import Snapshot

_DATA = EgmHeader.MessageType.Value("MSGTYPE_DATA")
_MOTORS = {True: 1, False: 2}  # EgmMotorState: MOTORS_ON, MOTORS_OFF
_RAPID = {True: 2, False: 1}  # EgmRapidCtrlExecState: RAPID_RUNNING, RAPID_STOPPED
_MCI_RUNNING = 3


class EgmServer:
    """The controller's end of an EGM session with the client at `client` (host, port);
    the controller's own UDP port is bound on `host` (any free port); `lose()` says whether
    a packet is lost on the way (None: none is)."""

    def __init__(
        self,
        client: tuple[str, int],
        host: str = "127.0.0.1",
        lose: Callable[[], bool] | None = None,
    ) -> None:
        self.client = client
        #: Whether the next packet is lost on the way (a network's loss, injected).
        self.lose = lose
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind((host, 0))
        self.sock.settimeout(0.2)
        self.port = int(self.sock.getsockname()[1])
        self.sent = 0
        self.lost = 0
        self.received = 0
        self.refused = 0
        self._seq = 0
        self._t0 = time.monotonic()
        self._lock = threading.Lock()
        self._joints: tuple[float, np.ndarray] | None = None
        self._pose: tuple[float, np.ndarray] | None = None
        self._closed = threading.Event()
        self._thread = threading.Thread(target=self._receive, name="twin-egm", daemon=True)
        self._thread.start()

    def close(self) -> None:
        self._closed.set()
        self._thread.join(timeout=2.0)
        self.sock.close()

    def active(self) -> bool:
        return not self._closed.is_set()

    # -- references -------------------------------------------------------------------------
    def _receive(self) -> None:
        while not self._closed.is_set():
            try:
                data, _addr = self.sock.recvfrom(65536)
            except TimeoutError:
                continue
            except OSError:
                return
            self._take(data)

    def _take(self, data: bytes) -> None:
        message: Any = EgmSensor()
        try:
            message.ParseFromString(data)
        except Exception:
            self.refused += 1
            return
        now = time.monotonic()
        planned = message.planned
        with self._lock:
            self.received += 1
            if len(planned.joints.joints) >= 6:
                self._joints = (now, np.deg2rad(np.array(planned.joints.joints[:6], dtype=float)))
                self._pose = None
            elif planned.HasField("cartesian"):
                c = planned.cartesian
                q = np.array([c.orient.u0, c.orient.u1, c.orient.u2, c.orient.u3], dtype=float)
                if not np.isclose(np.linalg.norm(q), 1.0, atol=1e-3):
                    self.refused += 1
                    return
                p = np.array([c.pos.x, c.pos.y, c.pos.z], dtype=float) * 1e-3
                self._pose = (now, make_T(quat_wxyz_to_R(q / np.linalg.norm(q)), p))
                self._joints = None
            else:
                self.refused += 1

    def reference(
        self, solve: Callable[[np.ndarray], np.ndarray], max_age_s: float
    ) -> np.ndarray | None:
        """The newest joint reference (6,) [rad] not older than `max_age_s` [s]: the joints
        sent, or the pose sent solved by `solve` (flange pose (4, 4) -> joints, the nominal
        arm's); None if none."""
        now = time.monotonic()
        with self._lock:
            joints, pose = self._joints, self._pose
        if joints is not None and now - joints[0] <= max_age_s:
            return joints[1]
        if pose is not None and now - pose[0] <= max_age_s:
            try:
                return solve(pose[1])
            except CellError:
                self.refused += 1
                with self._lock:
                    self._pose = None
        return None

    def fresh(self, max_age_s: float) -> bool:
        """Whether a reference not older than `max_age_s` [s] came."""
        now = time.monotonic()
        with self._lock:
            stamps = [r[0] for r in (self._joints, self._pose) if r is not None]
        return any(now - t <= max_age_s for t in stamps)

    def refuse_until_new(self) -> None:
        """Forget the reference (one the arm could not follow) until the client sends another."""
        with self._lock:
            self._joints = self._pose = None
        self.refused += 1

    # -- feedback ---------------------------------------------------------------------------
    def feedback(
        self,
        snap: Snapshot,
        motors_on: bool,
        rapid_running: bool,
        to_sensor: tuple[float, ...],
    ) -> None:
        """Send an EgmRobot message of the controller's snapshot `snap` to the client, with
        `to_sensor` in RAPIDfromRobot.dnum (TcHelper's tcToSensor)."""
        message: Any = EgmRobot()
        self._seq += 1
        message.header.seqno = self._seq
        message.header.tm = int((time.monotonic() - self._t0) * 1e3) & 0xFFFFFFFF
        message.header.mtype = _DATA
        feedback = message.feedBack
        feedback.joints.joints.extend(np.rad2deg(snap.q).tolist())
        _pose(feedback.cartesian, snap.T_base_flange)
        feedback.externalJoints.joints.append(snap.table_m * 1e3)  # axis A, a linear axis [mm]
        feedback.time.sec = int(snap.time_s)
        feedback.time.usec = int((snap.time_s % 1.0) * 1e6)
        message.planned.joints.joints.extend(np.rad2deg(snap.q_ref).tolist())
        message.motorState.state = _MOTORS[motors_on]
        message.mciState.state = _MCI_RUNNING
        message.rapidExecState.state = _RAPID[rapid_running]
        message.RAPIDfromRobot.dnum.extend(to_sensor)
        if self.lose is not None and self.lose():
            self.lost += 1
            return
        try:
            self.sock.sendto(message.SerializeToString(), self.client)
            self.sent += 1
        except OSError:  # the client's port is not open (yet): a datagram lost, as UDP's are
            self.lost += 1


def _pose(cartesian: Any, T: np.ndarray) -> None:
    w, x, y, z = R_to_quat_wxyz(T[:3, :3])  # every packet: scipy's Rotation costs ten times as much
    cartesian.pos.x, cartesian.pos.y, cartesian.pos.z = (T[:3, 3] * 1e3).tolist()
    cartesian.orient.u0, cartesian.orient.u1 = float(w), float(x)
    cartesian.orient.u2, cartesian.orient.u3 = float(y), float(z)
