"""The line laser's profile stream, as `twincell serve` sends it over TCP: one frame per
profile, little-endian, stamped in the sensor's own clock.

A frame is a header of 24 bytes, then `count` float32 distances [m] along the sensor's rays in
their data-sheet order (NaN: no return):

    offset  size  field
    0       4     magic b"TCPF"
    4       2     version (1)
    6       2     flags (0)
    8       4     seqno, uint32: the profile's number, +1 per profile (a gap: profiles lost)
    12      8     stamp, float64 [s]: the sensor's clock when the profile was exposed
    20      4     count, uint32: the number of distances that follow

A line profiler's own SDK (Gocator, scanCONTROL, ...) gives the same three things per profile:
a counter, a stamp in its clock, the ranges; an adapter turns them into `Profile`s.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

import numpy as np

from cell.cell_errors import CellError

MAGIC = b"TCPF"
VERSION = 1
HEADER = struct.Struct("<4sHHIdI")
#: The most rays a frame may carry (a frame of more is refused as corrupt).
MAX_COUNT = 65536


class ProfileFrameError(CellError, ValueError):
    """Bytes that are not a profile frame of this version; the message says what was read."""


@dataclass(frozen=True, eq=False)
class Profile:
    """One profile: its number `seqno`, the sensor's clock at its exposure `stamp_s` [s], and
    the distances (n_rays,) [m] (NaN: no return)."""

    seqno: int
    stamp_s: float
    distances: np.ndarray


def encode(profile: Profile) -> bytes:
    """The frame of `profile`."""
    ranges = np.asarray(profile.distances, dtype="<f4")
    header = HEADER.pack(
        MAGIC, VERSION, 0, profile.seqno & 0xFFFFFFFF, float(profile.stamp_s), ranges.size
    )
    return header + ranges.tobytes()


def body_size(header: bytes) -> int:
    """The number of bytes of distances that follow `header` (HEADER.size bytes)."""
    magic, version, _flags, _seq, _stamp, count = HEADER.unpack(header)
    if magic != MAGIC:
        raise ProfileFrameError(f"not a profile frame: it starts with {magic!r}, not {MAGIC!r}")
    if version != VERSION:
        raise ProfileFrameError(f"profile frame version {version}; this reader reads {VERSION}")
    if count > MAX_COUNT:
        raise ProfileFrameError(f"a profile frame of {count} rays (at most {MAX_COUNT})")
    return 4 * int(count)


def decode(header: bytes, body: bytes) -> Profile:
    """The profile of a frame: its `header` and the `body_size(header)` bytes after it."""
    size = body_size(header)
    if len(body) != size:
        raise ProfileFrameError(f"a profile frame of {len(body)} bytes of distances, not {size}")
    _magic, _version, _flags, seqno, stamp, _count = HEADER.unpack(header)
    distances = np.frombuffer(body, dtype="<f4").astype(float)
    return Profile(int(seqno), float(stamp), distances)
