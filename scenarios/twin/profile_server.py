"""The line laser's profile stream (cell.profile_frames) served over TCP: every client that
connects gets each profile from then on, as a line profiler's own Ethernet stream does.

The controller's worker hands profiles over without waiting (`send`); each client has its
own queue and thread that write them out. A client that falls `QUEUE` profiles behind loses
the profiles after those until it catches up: the gap in the profiles' numbers tells it.
"""

from __future__ import annotations

import queue
import socketserver
import threading

from cell.profile_frames import Profile, encode

#: How many profiles a client may fall behind before the oldest are dropped.
QUEUE = 2000


class _Handler(socketserver.BaseRequestHandler):
    server: _Server

    def handle(self) -> None:
        frames: queue.Queue[bytes | None] = queue.Queue(QUEUE)
        self.server.join(frames)
        try:
            while (frame := frames.get()) is not None:
                self.request.sendall(frame)
        except OSError:
            pass  # the client went away
        finally:
            self.server.leave(frames)


class _Server(socketserver.ThreadingTCPServer):
    daemon_threads = True
    allow_reuse_address = True

    def __init__(self, address: tuple[str, int]) -> None:
        super().__init__(address, _Handler)
        self.clients: list[queue.Queue[bytes | None]] = []
        self.lock = threading.Lock()

    def join(self, frames: queue.Queue[bytes | None]) -> None:
        with self.lock:
            self.clients.append(frames)

    def leave(self, frames: queue.Queue[bytes | None]) -> None:
        with self.lock:
            if frames in self.clients:
                self.clients.remove(frames)


class ProfileServer:
    """Serves profiles to TCP clients at `address` (host, port; port 0: any free one)."""

    def __init__(self, address: tuple[str, int]) -> None:
        self._server = _Server(address)
        self.port = int(self._server.server_address[1])
        self.sent = 0
        self.dropped = 0
        self._thread = threading.Thread(
            target=self._server.serve_forever, name="twin-profiles", daemon=True
        )
        self._thread.start()

    @property
    def clients(self) -> int:
        with self._server.lock:
            return len(self._server.clients)

    def send(self, profile: Profile) -> None:
        """Queue `profile` for every client connected now."""
        frame = encode(profile)
        with self._server.lock:
            clients = list(self._server.clients)
        for frames in clients:
            try:
                frames.put_nowait(frame)
            except queue.Full:
                self.dropped += 1
                continue
            self.sent += 1

    def close(self) -> None:
        with self._server.lock:
            clients = list(self._server.clients)
        for frames in clients:
            frames.put(None)
        self._server.shutdown()
        self._server.server_close()
