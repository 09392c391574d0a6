"""PLY files read by numpy: the vertices' x, y, z and the triangles, ascii or binary (either
byte order), in one array operation per element.

This covers what scanners and mesh tools write: a vertex element of scalar properties
(x, y, z among them, any others ignored), an optional face element whose one list property
(vertex_indices or vertex_index) holds three indices per face, and any other elements,
skipped wherever they stand (a range scanner's `range_grid`, edges, materials). A file
beyond that (polygons other than triangles, a list property of the vertices, a header this
reader does not know, faces cut short) is left to trimesh (`read_ply` returns None), which
reads every PLY the project accepted before and says what is wrong with the others.
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from registration.registration_errors import FormatError
from registration.rigid import Array

#: PLY's scalar types and their numpy codes (both the classic and the sized names).
SCALAR_TYPES: dict[str, str] = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}  # fmt: skip
_FORMATS = {"ascii": "", "binary_little_endian": "<", "binary_big_endian": ">"}
_FACE_LISTS = ("vertex_indices", "vertex_index")


@dataclass(frozen=True)
class PlyProperty:
    """One property of an element: a scalar, or a list (`count_type` set) of `type`."""

    name: str
    type: str
    count_type: str | None = None


@dataclass(frozen=True)
class PlyElement:
    name: str
    count: int
    properties: tuple[PlyProperty, ...]


@dataclass(frozen=True)
class PlyHeader:
    """The header's format ("ascii", "binary_little_endian", "binary_big_endian"), its
    elements in file order, and the byte offset where their data start."""

    format: str
    elements: tuple[PlyElement, ...]
    data_start: int


class _BeyondError(Exception):
    """A file this reader leaves to trimesh."""


def _property(parts: list[str]) -> PlyProperty:
    if len(parts) == 3 and parts[1] in SCALAR_TYPES:
        return PlyProperty(parts[2], SCALAR_TYPES[parts[1]])
    if (
        len(parts) == 5
        and parts[1] == "list"
        and parts[2] in SCALAR_TYPES
        and parts[3] in SCALAR_TYPES
    ):
        return PlyProperty(parts[4], SCALAR_TYPES[parts[3]], SCALAR_TYPES[parts[2]])
    raise _BeyondError(f"property line {' '.join(parts)!r}")


def parse_header(data: bytes) -> PlyHeader:
    """The header at the start of `data` (raises _BeyondError if this reader does not know it)."""
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise _BeyondError("no PLY header")
    stop = data.find(b"\n", end)
    if stop < 0:
        raise _BeyondError("no data after the header")
    lines = data[:end].decode("ascii", "replace").splitlines()[1:]
    fmt = ""
    elements: list[PlyElement] = []
    for line in lines:
        parts = line.split()
        if not parts or parts[0] in ("comment", "obj_info"):
            continue
        if parts[0] == "format" and len(parts) == 3 and parts[1] in _FORMATS:
            fmt = parts[1]
        elif parts[0] == "element" and len(parts) == 3 and parts[2].isdigit():
            elements.append(PlyElement(parts[1], int(parts[2]), ()))
        elif parts[0] == "property" and elements:
            last = elements[-1]
            elements[-1] = PlyElement(last.name, last.count, (*last.properties, _property(parts)))
        else:
            raise _BeyondError(f"header line {line!r}")
    if not fmt:
        raise _BeyondError("no format line")
    return PlyHeader(fmt, tuple(elements), stop + 1)


def _record(element: PlyElement, order: str) -> np.dtype:
    """The binary record of an element; a face's list as exactly three indices."""
    fields: list[tuple[str, str] | tuple[str, str, tuple[int]]] = []
    for k, prop in enumerate(element.properties):
        if prop.count_type is None:
            fields.append((f"p{k}", order + prop.type))
            continue
        if element.name != "face" or prop.name not in _FACE_LISTS:
            raise _BeyondError(f"a list property {prop.name!r} of element {element.name!r}")
        fields.append(("count", order + prop.count_type))
        fields.append(("corners", order + prop.type, (3,)))
    return np.dtype(fields)


def _vertices(element: PlyElement, table: np.ndarray, column: str) -> Array:
    """x, y, z (V, 3) as float64 from a vertex element's records or columns."""
    names = [prop.name for prop in element.properties]
    if any(axis not in names for axis in "xyz"):
        raise _BeyondError("a vertex element without x, y and z")
    index = [names.index(axis) for axis in "xyz"]
    if column == "fields":
        return np.stack([table[f"p{k}"] for k in index], axis=1).astype(float)
    # Text read as float64, rounded to the type the header declares (as trimesh reads it).
    types = [element.properties[k].type for k in index]
    return np.stack([table[:, k].astype(t) for k, t in zip(index, types, strict=True)], 1).astype(
        float
    )


def _truncated(p: Path, vertex: PlyElement, read: int) -> FormatError:
    return FormatError(
        f"{p}: its header declares {vertex.count} vertices but {read} were read (a truncated file?)"
    )


def _binary(p: Path, data: bytes, header: PlyHeader) -> tuple[Array, Array | None]:
    order = _FORMATS[header.format]
    offset = header.data_start
    vertices: Array | None = None
    faces: Array | None = None
    wanted = _wanted(header)
    for element in header.elements:
        if vertices is not None and (faces is not None or "face" not in wanted):
            break
        if element.name not in wanted:
            offset = _skip(data, offset, element, order)
            continue
        record = _record(element, order)
        available = (len(data) - offset) // record.itemsize
        if available < element.count:
            if element.name == "vertex":
                raise _truncated(p, element, available)
            raise _BeyondError("faces cut short, or faces other than triangles")
        table = np.frombuffer(data, record, element.count, offset)
        offset += element.count * record.itemsize
        if element.name == "vertex":
            vertices = _vertices(element, table, "fields")
        else:
            if "corners" not in (table.dtype.names or ()) or not (table["count"] == 3).all():
                raise _BeyondError("faces other than triangles")
            faces = table["corners"].astype(np.int64)
    if vertices is None:
        raise _BeyondError("no vertex element")
    return vertices, faces


def _wanted(header: PlyHeader) -> dict[str, PlyElement]:
    """The vertex element and the face element if there is one; any other is skipped."""
    names = [element.name for element in header.elements]
    if names.count("vertex") != 1 or names.count("face") > 1:
        raise _BeyondError(f"elements {names}")
    return {e.name: e for e in header.elements if e.name in ("vertex", "face")}


def _skip(data: bytes, offset: int, element: PlyElement, order: str) -> int:
    """The offset past a binary element this reader does not read: its records' sizes, a
    list property's counts read record by record."""
    if all(prop.count_type is None for prop in element.properties):
        size = sum(np.dtype(prop.type).itemsize for prop in element.properties)
        return offset + element.count * size
    # Per property: its item size, and for a list its count's size and signedness.
    layout = [
        (
            np.dtype(prop.type).itemsize,
            None if prop.count_type is None else np.dtype(prop.count_type).itemsize,
            prop.count_type is not None and np.dtype(prop.count_type).kind == "i",
        )
        for prop in element.properties
    ]
    byteorder: Literal["little", "big"] = "big" if order == ">" else "little"
    for _ in range(element.count):
        for size, count_size, signed in layout:
            if count_size is None:
                offset += size
                continue
            if offset + count_size > len(data):
                raise _BeyondError(f"element {element.name!r} cut short")
            count = int.from_bytes(data[offset : offset + count_size], byteorder, signed=signed)
            offset += count_size + count * size
    return offset


def _ascii(p: Path, data: bytes, header: PlyHeader, faces: bool) -> tuple[Array, Array | None]:
    """An ascii PLY: one line per record of each element, in the header's order; the vertex
    lines read, the face lines (three indices after the count) read if `faces`, those of
    any other element skipped."""
    wanted = _wanted(header)
    vertex = wanted["vertex"]
    if any(prop.count_type is not None for prop in vertex.properties):
        raise _BeyondError("a list property of the vertices")
    if vertex.count == 0:
        return np.zeros((0, 3)), None
    first: dict[str, int] = {}  # each element's first line
    line = 0
    for element in header.elements:
        first[element.name] = line
        line += element.count
    body = data[header.data_start :]
    # Where each line ends (a last line without its newline ends at the end of the file).
    ends = np.flatnonzero(np.frombuffer(body, np.uint8) == ord("\n"))
    if body and not body.endswith(b"\n"):
        ends = np.append(ends, len(body))

    def block(name: str) -> bytes:
        start, count = first[name], wanted[name].count
        begin = int(ends[start - 1]) + 1 if start else 0
        return body[begin : int(ends[start + count - 1]) + 1]

    if len(ends) < first["vertex"] + vertex.count:
        raise _truncated(p, vertex, max(len(ends) - first["vertex"], 0))
    table = _table(block("vertex"), vertex.count, len(vertex.properties))
    vertices = _vertices(vertex, table, "columns")
    face = wanted.get("face")
    if face is None or face.count == 0:
        return vertices, None
    props = face.properties
    if len(props) != 1 or props[0].count_type is None or props[0].name not in _FACE_LISTS:
        raise _BeyondError("face properties other than one list of indices")
    if len(ends) < first["face"] + face.count:
        raise _BeyondError("faces cut short")
    if not faces:
        return vertices, None
    table = _table(block("face"), face.count, 4)
    if not (table[:, 0] == 3).all() or not (table == np.round(table)).all():
        raise _BeyondError("faces other than triangles")
    return vertices, table[:, 1:].astype(np.int64)


def _table(block: bytes, rows: int, columns: int) -> np.ndarray:
    """The numbers (rows, columns) of a block of text lines."""
    try:
        text = io.StringIO(block.decode("ascii"))
        table = np.loadtxt(text, ndmin=2, comments=None)
    except (ValueError, UnicodeDecodeError) as exc:
        raise _BeyondError(f"rows that are not {columns} numbers") from exc
    if table.shape != (rows, columns):
        raise _BeyondError(f"rows that are not {columns} numbers")
    return table


def read_ply(p: Path, faces: bool = True) -> tuple[Array, Array | None] | None:
    """Vertices (V, 3) [file units] and triangles (F, 3) (None without faces, or if `faces`
    is False) of a PLY file; None if the file is beyond this reader (see the module's
    docstring: trimesh reads it).

    Raises FormatError if the vertices stop before the count the header declares.
    """
    data = p.read_bytes()
    try:
        header = parse_header(data)
        if header.format == "ascii":
            return _ascii(p, data, header, faces)
        vertices, triangles = _binary(p, data, header)
        return vertices, triangles if faces else None
    except _BeyondError:
        return None
