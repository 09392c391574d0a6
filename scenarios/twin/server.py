"""A served controller: the twin's state (scenarios.twin.twin_controller) behind RWS on an HTTP
port and, if asked, an EGM session with a client's UDP port and the line laser's profile
stream on a TCP port; started and stopped as one."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

from scenarios.twin.controller_errors import bad_request
from scenarios.twin.digest import DEFAULT_USERS
from scenarios.twin.egm import EgmServer
from scenarios.twin.guidance import Guidance
from scenarios.twin.http import Server
from scenarios.twin.network_faults import Draws, NetworkFaults
from scenarios.twin.profile_server import ProfileServer
from scenarios.twin.rws import Rws
from scenarios.twin.sensor_streams import LaserStream, SensorStreams
from scenarios.twin.twin_controller import TwinController


@dataclass(frozen=True)
class ServeOptions:
    """Where and how to serve: RWS on host:port (port 0: any free one), EGM to the client
    at egm_host:egm_port (None: no EGM), the laser's profiles on host:profiles_port (None: no
    profile stream; 0: any free port) as `laser` says, the users (name -> password), the
    controller's operation mode (AUTO, or MANR: clients read only), and the network's faults
    injected."""

    host: str = "127.0.0.1"
    port: int = 8080
    egm_port: int | None = None
    egm_host: str = "127.0.0.1"
    users: tuple[tuple[str, str], ...] = tuple(DEFAULT_USERS.items())
    opmode: str = "AUTO"
    profiles_port: int | None = None
    laser: LaserStream = field(default_factory=LaserStream)
    faults: NetworkFaults = field(default_factory=NetworkFaults)
    #: The transmission protocol (UDP device) of the system configuration EGM streams to:
    #: the one the helper module's TcStream names (scenarios.irc5.helper_module.UDP_DEVICE).
    egm_device: str = "TcPC"


class ServedController:
    """RWS (and EGM) serving `twin` from a thread of their own until `close()`."""

    def __init__(self, twin: TwinController, options: ServeOptions) -> None:
        self.twin = twin
        self.rws = Rws(twin)
        draws = Draws(options.faults)
        late = options.faults.rws_latency_s + options.faults.rws_jitter_s > 0.0
        self.http = Server(
            (options.host, options.port), self.rws.route, self.rws.subscriptions.serve,
            dict(options.users), draws.rws_delay_s if late else None,
        )  # fmt: skip
        self.egm: EgmServer | None = None
        if options.egm_port is not None:
            lose = draws.egm_lost if options.faults.egm_loss > 0.0 else None
            self.egm = EgmServer((options.egm_host, options.egm_port), options.host, lose)
            self.rws.udp_devices[options.egm_device] = (options.egm_host, options.egm_port)
            twin.guidance = Guidance(twin.cell, self.egm, twin.elog)
        self.profiles: ProfileServer | None = None
        if options.profiles_port is not None:
            self.profiles = ProfileServer((options.host, options.profiles_port))
        twin.streams = SensorStreams(self.egm, self.profiles, options.laser, twin.pacer.speed)

    @property
    def url(self) -> str:
        """The RWS base URL, e.g. http://127.0.0.1:8080."""
        return self.http.base

    def close(self) -> None:
        """Stop serving, halt what moves, and close the EGM session."""
        self.http.close()
        self.twin.close()
        if self.egm is not None:
            self.egm.close()
        self.twin.streams.close()


def parse_address(text: str) -> tuple[str, int]:
    """HOST:PORT (port 0: any free one); ControllerError naming what was given."""
    host, sep, port = text.rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 <= int(port) <= 65535:
        raise bad_request(f"{text!r}: give HOST:PORT, e.g. 127.0.0.1:8080")
    return host, int(port)


def parse_users(texts: Iterable[str]) -> tuple[tuple[str, str], ...]:
    """NAME:PASSWORD each; none given: the controller's default user."""
    users = []
    for text in texts:
        name, sep, password = text.partition(":")
        if not sep or not name or not password:
            raise bad_request(f"user {text!r}: give NAME:PASSWORD")
        users.append((name, password))
    return tuple(users) or tuple(DEFAULT_USERS.items())
