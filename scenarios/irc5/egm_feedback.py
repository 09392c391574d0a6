"""The controller's EGM position stream, received on a thread of its own: every sample of the
encoders with the controller's time it was read at (`feedBack.time`), the table as external
axis A, the motors' and RAPID's states, and the client's clock when it came.

The stream comes at 250 Hz over UDP (abb_robot_client's EGM reads it). A command waits for
a sample that came after it was given (`after`), and nothing is commanded on a stream older
than `max_age_s` (`fresh`): a link that went quiet stops the job (LinkError).
"""

from __future__ import annotations

import contextlib
import socket
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from abb_robot_client.egm import EGM

from scenarios.irc5.link_errors import ControllerRefusalError, LinkError

#: The stream's period on an IRC5 [s] (EGM application manual, 3HAC073318-001: 4 ms).
PERIOD_S = 0.004
#: The UDP receive buffer asked for [bytes] (the kernel may cap it: net.core.rmem_max).
RECEIVE_BUFFER = 4 * 1024 * 1024


@dataclass(frozen=True, eq=False)
class Feedback:
    """One sample of the stream: the client's monotonic clock when it came `received_s` [s],
    the controller's clock when the encoders were read `time_s` [s], the header's sequence
    number, the encoders q (6,) [rad], the table [m] (None: no external axis), RAPID running,
    motors on, the beam of the TCP check (broken: the helper module TcHelper's
    DataToSensor tcToSensor{1}, the first dnum of RAPIDfromRobot, is 1; None: the packet
    carries no RAPIDfromRobot, see `beam_of`), and the point laser's input aiLaserRange [mm]
    with the count of its readings (tcToSensor{2} and {3}; None: not streamed)."""

    received_s: float
    time_s: float
    seqno: int
    q: np.ndarray
    table_m: float | None
    rapid_running: bool
    motors_on: bool
    beam: bool | None = False
    laser_mm: float | None = None
    laser_reads: int | None = None


def feedback_of(state: Any, received_s: float) -> Feedback:
    """The sample of an abb_robot_client EGMRobotState received at `received_s`."""
    message = state.robot_message
    clock = message.feedBack.time
    external = state.external_axes
    table = float(external[0]) * 1e-3 if external is not None and len(external) else None
    return Feedback(
        received_s,
        float(clock.sec) + float(clock.usec) * 1e-6,
        int(message.header.seqno),
        np.deg2rad(np.asarray(state.joint_angles[:6], dtype=float)),
        table,
        bool(state.rapid_running),
        bool(state.motors_on),
        _beam(dnum := message.RAPIDfromRobot.dnum),
        float(dnum[1]) if len(dnum) > 2 else None,
        int(dnum[2]) if len(dnum) > 2 else None,
    )


def _beam(dnum: Any) -> bool | None:
    """TcHelper's tcToSensor{1}: 1 while the beam is broken (no value: not known)."""
    return float(dnum[0]) > 0.5 if len(dnum) > 0 else None


def beam_of(sample: Feedback) -> bool:
    """The beam in a sample of the stream; raises ControllerRefusalError where the stream
    carries no RAPIDfromRobot: the controller's EGM sends no DataToSensor values (RobotWare
    6.07-6.10's egm.proto has no such field), or the helper module's TcStream did not start
    the stream with them."""
    if sample.beam is None:
        raise ControllerRefusalError(
            "the controller's EGM stream carries no RAPIDfromRobot values, so the TCP "
            "check's beam cannot be read with the joints: the helper module TcHelper starts "
            "it with EGMActJoint \\DataToSensor, which needs a RobotWare whose EGM sends "
            "RAPIDfromRobot (not 6.07-6.10): update the controller's RobotWare"
        )
    return sample.beam


class EgmFeedback:
    """The position stream the controller sends to this client's UDP `port`; the last
    `keep_s` [s] of it are kept."""

    def __init__(self, port: int, keep_s: float = 300.0) -> None:
        self.port = port
        self._egm = EGM(port)
        # room for a second of the stream at a twin's speed of 20 while this process is busy
        self._egm.socket.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, RECEIVE_BUFFER)
        self._samples: deque[Feedback] = deque(maxlen=int(keep_s / PERIOD_S))
        self._changed = threading.Condition()
        self._closed = threading.Event()
        #: Samples received, and samples the sequence numbers say were lost on the way.
        self.received = 0
        self.lost = 0
        #: Called with each sample as it comes, on the stream's thread (a point laser's reader).
        self.listeners: list[Callable[[Feedback], None]] = []
        self._thread = threading.Thread(target=self._receive, name="egm-feedback", daemon=True)
        self._thread.start()

    def _receive(self) -> None:
        while not self._closed.is_set():
            try:
                ok, state = self._egm.receive_from_robot(0.1)
            except OSError:
                return  # closed
            if not ok or state is None or state.joint_angles is None:
                continue
            sample = feedback_of(state, time.monotonic())
            with self._changed:
                if self._samples and sample.seqno > self._samples[-1].seqno + 1:
                    self.lost += sample.seqno - self._samples[-1].seqno - 1
                self._samples.append(sample)
                self.received += 1
                self._changed.notify_all()
            for listener in list(self.listeners):
                listener(sample)

    def latest(self) -> Feedback | None:
        with self._changed:
            return self._samples[-1] if self._samples else None

    def fresh(self, max_age_s: float, wait_s: float = 1.0) -> Feedback:
        """The newest sample, if it came within `max_age_s` [s], else the next one if it
        comes within `wait_s` [s] (a stream that paused: a busy computer); LinkError if
        none does."""
        sample = self.latest()
        now = time.monotonic()
        if sample is not None and now - sample.received_s > max_age_s and wait_s > 0.0:
            with contextlib.suppress(LinkError):
                return self.after(now, wait_s)
            now = time.monotonic()
        if sample is None:
            raise LinkError(
                f"no EGM feedback has come to UDP port {self.port}: is the controller's EGM "
                "stream started and sent to this computer's address and port?"
            )
        if now - sample.received_s > max_age_s:
            raise LinkError(
                f"the EGM feedback is stale: the newest came {now - sample.received_s:.3f} s "
                f"ago (at most {max_age_s:g} s, and none came in {wait_s:g} s more); nothing is "
                "commanded on a stale reading"
            )
        return sample

    def after(self, since_s: float, timeout_s: float) -> Feedback:
        """The first sample that came after `since_s` (the client's monotonic clock [s]),
        waiting up to `timeout_s` [s] for it; LinkError if none came."""
        deadline = time.monotonic() + timeout_s
        with self._changed:
            while True:
                first = None
                for sample in reversed(self._samples):
                    if sample.received_s <= since_s:
                        break
                    first = sample
                if first is not None:
                    return first
                left = deadline - time.monotonic()
                if left <= 0.0:
                    raise LinkError(
                        f"no EGM feedback came within {timeout_s:g} s (UDP port {self.port})"
                    )
                self._changed.wait(left)

    def stopped_after_running(self, since_s: float, wait_s: float) -> bool:
        """Whether, among the samples that came after `since_s` (the client's monotonic clock
        [s]), one says RAPID runs and a later one that it stopped; waits up to `wait_s` [s]."""
        deadline = time.monotonic() + wait_s
        ran, seen_s = False, since_s  # each sample looked at once, as it comes
        with self._changed:
            while True:
                for sample in self._samples_since(seen_s):
                    seen_s = sample.received_s
                    if sample.rapid_running:
                        ran = True
                    elif ran:
                        return True
                left = deadline - time.monotonic()
                if left <= 0.0:
                    return False
                self._changed.wait(left)

    def _samples_since(self, since_s: float) -> list[Feedback]:
        out = []
        for sample in reversed(self._samples):
            if sample.received_s <= since_s:
                break
            out.append(sample)
        return out[::-1]

    def since(self, received_s: float) -> list[Feedback]:
        """The samples that came after `received_s` (the client's monotonic clock [s])."""
        with self._changed:
            return self._samples_since(received_s)

    def close(self) -> None:
        self._closed.set()
        self._egm.close()
        self._thread.join(timeout=2.0)
