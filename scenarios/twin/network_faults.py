"""What the network between the served controller and its clients does to them, injected on
purpose (all off by default): the RWS answers late by a latency and a random jitter, EGM
packets are lost, and the line laser's clock runs fast or slow against the controller's. A
client of a real cell meets each of these; the twin lets a test meet them on demand."""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np

from scenarios.twin.controller_errors import bad_request


@dataclass(frozen=True)
class NetworkFaults:
    """The RWS answers' latency and the width of their uniform jitter [s], the share of EGM
    packets lost (0 to 1), the laser clock's drift against the controller's [ppm], and the
    seed of the draws."""

    rws_latency_s: float = 0.0
    rws_jitter_s: float = 0.0
    egm_loss: float = 0.0
    laser_drift_ppm: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        if not (self.rws_latency_s >= 0.0 and self.rws_jitter_s >= 0.0):
            raise bad_request(
                f"RWS latency {self.rws_latency_s!r} s, jitter {self.rws_jitter_s!r} s: give >= 0"
            )
        if not 0.0 <= self.egm_loss < 1.0:
            raise bad_request(f"EGM loss {self.egm_loss!r}: give a share in [0, 1)")
        if not abs(self.laser_drift_ppm) <= 1e4:
            raise bad_request(f"laser drift {self.laser_drift_ppm!r} ppm: give at most 1e4")


class Draws:
    """The random draws of `faults`, from threads of their own (the RWS executor, the
    controller's worker)."""

    def __init__(self, faults: NetworkFaults) -> None:
        self.faults = faults
        self._rng = np.random.default_rng(faults.seed)
        self._lock = threading.Lock()

    def rws_delay_s(self) -> float:
        """How late the next RWS answer is [s]."""
        f = self.faults
        if f.rws_jitter_s == 0.0:
            return f.rws_latency_s
        with self._lock:
            return f.rws_latency_s + float(self._rng.uniform(0.0, f.rws_jitter_s))

    def egm_lost(self) -> bool:
        """Whether the next EGM packet is lost."""
        if self.faults.egm_loss == 0.0:
            return False
        with self._lock:
            return bool(self._rng.random() < self.faults.egm_loss)
