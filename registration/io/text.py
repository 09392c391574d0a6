"""Text and numpy point files: .xyz / .txt / .pts, .csv, .npy."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from registration.errors import FormatError, first_line
from registration.rigid import Array


def _rows(p: Path, delimiter: str | None) -> tuple[list[list[float]], int | None]:
    """The x y z rows of a text file and the count its first line states, if any."""
    rows: list[list[float]] = []
    count: int | None = None
    first = True
    try:
        text = p.read_text()
    except UnicodeDecodeError:
        raise FormatError(f"{p}: not a text file (a binary file with a text suffix?)") from None
    for number, line in enumerate(text.splitlines(), start=1):
        body = line.split("#", 1)[0].strip()
        if not body:
            continue
        fields = body.split(delimiter) if delimiter else body.split()
        try:
            values = [float(f) for f in fields]
        except ValueError:
            if first and not rows:
                first = False
                continue  # a header line
            raise FormatError(
                f"{p}:{number}: expected numbers, got {line.strip()[:60]!r}"
            ) from None
        if first and not rows and len(values) == 1:
            first = False
            if not values[0].is_integer() or values[0] < 0:
                raise FormatError(
                    f"{p}:{number}: a count line must be a whole number; got {fields[0]}"
                )
            count = int(values[0])
            continue  # the optional count line
        first = False
        if len(values) < 3:
            raise FormatError(f"{p}:{number}: expected x y z, got {len(values)} value(s)")
        rows.append(values[:3])
    return rows, count


def _text(p: Path, delimiter: str | None) -> Array:
    rows, count = _rows(p, delimiter)
    if not rows:
        raise FormatError(f"{p}: holds no points")
    if count is not None and count != len(rows):
        raise FormatError(f"{p}: its count line says {count} points, but it holds {len(rows)} rows")
    return np.asarray(rows, dtype=float)


def read_xyz(p: Path) -> Array:
    """x y z per line (whitespace), an optional count line and header, '#' comments."""
    return _text(p, None)


def read_csv(p: Path) -> Array:
    """x,y,z per line, an optional header line."""
    return _text(p, ",")


def read_npy(p: Path) -> Array:
    """An (N, 3) numpy array."""
    try:
        a = np.load(p, allow_pickle=False)
    except (ValueError, OSError, EOFError) as exc:
        raise FormatError(f"{p}: not a readable .npy array ({first_line(exc)})") from None
    if not isinstance(a, np.ndarray) or not np.issubdtype(a.dtype, np.number):
        raise FormatError(f"{p}: holds {getattr(a, 'dtype', type(a))}, not numbers")
    return a
