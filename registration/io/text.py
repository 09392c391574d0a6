"""Text and numpy point files: .xyz / .txt / .pts, .csv, .npy.

A regular file (printable ASCII, one optional header or count line, then rows of as many
numbers each) is parsed by numpy's C reader in one call; anything else (other characters,
rows of different lengths, a word among the numbers, an empty file) goes through the line
by line reader, which accepts the same files and names the line that is wrong.
"""

from __future__ import annotations

import io
import re
from pathlib import Path

import numpy as np

from registration.registration_errors import FormatError, first_line
from registration.rigid import Array

#: What the fast path leaves to the line reader: any character other than printable ASCII,
#: a tab or a newline (Python's str.splitlines and str.split also break at form feeds, file
#: separators and the like, numpy's reader does not).
_IRREGULAR = re.compile(r"[^\t\n\x20-\x7e]")
#: A line that holds something other than blanks and a comment.
_CONTENT = re.compile(r"^[ \t]*[^#\s]", re.MULTILINE)


def _read_text(p: Path) -> str:
    try:
        return p.read_text()
    except UnicodeDecodeError:
        raise FormatError(f"{p}: not a text file (a binary file with a text suffix?)") from None


def _rows(p: Path, text: str, delimiter: str | None) -> tuple[list[list[float]], int | None]:
    """The x y z rows of a text file and the count its first line states, if any."""
    rows: list[list[float]] = []
    count: int | None = None
    first = True
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


def _first_line(text: str, delimiter: str | None) -> tuple[int, int | None] | None:
    """Where the rows start (after a header or count line, if the first line with content
    is one) and the count it states; None if the line reader must decide."""
    start = 0
    while start < len(text):
        end = text.find("\n", start)
        end = len(text) if end < 0 else end + 1
        body = text[start:end].split("#", 1)[0].strip()
        if body:
            fields = body.split(delimiter) if delimiter else body.split()
            try:
                values = [float(f) for f in fields]
            except ValueError:
                return end, None  # a header line
            if len(values) != 1:
                return start, None  # the first row
            if not values[0].is_integer() or values[0] < 0:
                return None  # a bad count line: the line reader says so
            return end, int(values[0])
        start = end
    return None


def _fast_rows(text: str, delimiter: str | None) -> tuple[Array, int | None] | None:
    """The x y z rows (N, 3) and the stated count of a regular file in one numpy call, or
    None where the line reader must read it (see the module's docstring)."""
    if _IRREGULAR.search(text) is not None:
        return None
    first = _first_line(text, delimiter)
    if first is None:
        return None
    start, count = first
    body = text[start:]
    if _CONTENT.search(body) is None:
        return None
    try:
        a = np.loadtxt(io.StringIO(body), delimiter=delimiter, comments="#", ndmin=2)
    except ValueError:  # a word, an empty field, rows of different lengths
        return None
    if a.shape[1] < 3:
        return None
    return np.ascontiguousarray(a[:, :3]), count


def _text(p: Path, delimiter: str | None) -> Array:
    text = _read_text(p)
    fast = _fast_rows(text, delimiter)
    if fast is not None:
        points, count = fast
    else:
        rows, count = _rows(p, text, delimiter)
        if not rows:
            raise FormatError(f"{p}: holds no points")
        points = np.asarray(rows, dtype=float)
    if count is not None and count != len(points):
        raise FormatError(
            f"{p}: its count line says {count} points, but it holds {len(points)} rows"
        )
    return points


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
