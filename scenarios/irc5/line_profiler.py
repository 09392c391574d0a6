"""The line laser as the client reads it: a `LineProfiler` streams profiles stamped in the
sensor's own clock, and a `ProfileBuffer` keeps them with the client's clock when each came.

`LineProfiler` is the adapter a user writes for their sensor's SDK (LMI's GoSDK, Micro-
Epsilon's scanCONTROL, ...): started with a callback, it hands over each profile as a
cell.profile_frames.Profile (the sensor's counter, its stamp, the ranges along the rays of
the laser's data sheet, in metres). `ProfileStream` is the one for `twincell serve`'s own
stream (the frames cell.profile_frames documents, over TCP).
"""

from __future__ import annotations

import contextlib
import socket
import threading
import time
from abc import ABC, abstractmethod
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

from cell.profile_frames import HEADER, Profile, ProfileFrameError, body_size, decode
from scenarios.irc5.link_errors import LinkError

ProfileSink = Callable[[Profile], None]


class LineProfiler(ABC):
    """A line profiler's stream of profiles."""

    #: Whether the profiles are stamped in the controller's own clock (a sensor read on the
    #: controller's input: no offset between the clocks to measure).
    controller_clock = False

    @abstractmethod
    def start(self, sink: ProfileSink) -> None:
        """Start streaming: `sink(profile)` for each profile, from a thread of the adapter's."""

    @abstractmethod
    def stop(self) -> None:
        """Stop streaming and release the sensor."""


class ProfileStream(LineProfiler):
    """The profile stream `twincell serve --profiles` sends from `host`:`port` (TCP)."""

    def __init__(self, host: str, port: int, timeout_s: float = 5.0) -> None:
        self.address = (host, port)
        self._timeout_s = timeout_s
        self._sock: socket.socket | None = None
        self._thread: threading.Thread | None = None
        #: Why the stream ended, if it ended by itself (the sensor gone, a corrupt frame).
        self.ended: str | None = None

    def start(self, sink: ProfileSink) -> None:
        try:
            self._sock = socket.create_connection(self.address, timeout=self._timeout_s)
        except OSError as exc:
            host, port = self.address
            raise LinkError(f"the profile stream at {host}:{port} does not answer: {exc}") from exc
        self._sock.settimeout(None)
        self._thread = threading.Thread(
            target=self._receive, args=(self._sock, sink), name="profiles", daemon=True
        )
        self._thread.start()

    def _receive(self, sock: socket.socket, sink: ProfileSink) -> None:
        try:
            while True:
                header = _read(sock, HEADER.size)
                sink(decode(header, _read(sock, body_size(header))))
        except (OSError, EOFError, ProfileFrameError) as exc:
            self.ended = str(exc) or type(exc).__name__

    def stop(self) -> None:
        if self._sock is not None:
            with contextlib.suppress(OSError):  # already gone
                self._sock.shutdown(socket.SHUT_RDWR)
            self._sock.close()
        if self._thread is not None:
            self._thread.join(timeout=2.0)


def _read(sock: socket.socket, size: int) -> bytes:
    chunks, left = [], size
    while left > 0:
        chunk = sock.recv(left)
        if not chunk:
            raise EOFError("the profile stream closed")
        chunks.append(chunk)
        left -= len(chunk)
    return b"".join(chunks)


@dataclass(frozen=True, eq=False)
class Received:
    """A profile and the client's monotonic clock when it came [s]."""

    received_s: float
    profile: Profile


class ProfileBuffer:
    """The last `keep` profiles of a LineProfiler, each with the client's clock when it came."""

    def __init__(self, sensor: LineProfiler, keep: int = 50_000) -> None:
        self.sensor = sensor
        self._profiles: deque[Received] = deque(maxlen=keep)
        self._changed = threading.Condition()
        #: Profiles received, and those the sensor's counter says were lost on the way.
        self.received = 0
        self.lost = 0
        sensor.start(self._take)

    def _take(self, profile: Profile) -> None:
        with self._changed:
            if self._profiles and profile.seqno > self._profiles[-1].profile.seqno + 1:
                self.lost += profile.seqno - self._profiles[-1].profile.seqno - 1
            self._profiles.append(Received(time.monotonic(), profile))
            self.received += 1
            self._changed.notify_all()

    def since(self, received_s: float) -> list[Received]:
        """The profiles that came after `received_s` (the client's monotonic clock [s])."""
        with self._changed:
            return [r for r in self._profiles if r.received_s > received_s]

    def after(self, received_s: float, timeout_s: float) -> Received:
        """The first profile that came after `received_s`, waiting up to `timeout_s` [s]."""
        deadline = time.monotonic() + timeout_s
        with self._changed:
            while True:
                first = None
                for r in reversed(self._profiles):
                    if r.received_s <= received_s:
                        break
                    first = r
                if first is not None:
                    return first
                left = deadline - time.monotonic()
                if left <= 0.0:
                    raise LinkError(
                        f"no laser profile came within {timeout_s:g} s: is the laser in hand "
                        "and its stream connected?"
                    )
                self._changed.wait(left)

    def until(self, stamp_s: float, timeout_s: float) -> None:
        """Wait up to `timeout_s` [s] for a profile stamped at `stamp_s` [s] or later (the
        stream is in order: every profile before it has come then); LinkError if none."""
        deadline = time.monotonic() + timeout_s
        with self._changed:
            while not self._profiles or self._profiles[-1].profile.stamp_s < stamp_s - 1e-6:
                left = deadline - time.monotonic()
                if left <= 0.0:
                    raise LinkError(
                        f"the laser's profiles stopped coming before the sensor's clock read "
                        f"{stamp_s:.3f} s (within {timeout_s:g} s)"
                    )
                self._changed.wait(left)

    def close(self) -> None:
        self.sensor.stop()
