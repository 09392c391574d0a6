"""A RAPID module written back with one work object's object frame (`oframe`) corrected.

A robtarget is the TCP pose in its work object's object frame, so the controller moves the
TCP to uframe @ oframe @ robtarget: correcting `oframe` corrects every target of that work
object, and the rest of the module's text is kept as it is.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from scenarios.rapid.module import RapidModule, find_wobj
from scenarios.rapid.parser import Parser


def _format(x: float, decimals: int) -> str:
    text = f"{x:.{decimals}f}".rstrip("0").rstrip(".")
    return "0" if text in ("", "-0", "-") else text


def position_text(T: np.ndarray, separator: str = ",") -> str:
    """A RAPID pos [x,y,z] of T's translation (4, 4) [m]: mm to 4 decimals, trailing zeros
    dropped."""
    return f"[{separator.join(_format(v, 4) for v in T[:3, 3] * 1e3)}]"


def orientation_text(T: np.ndarray, separator: str = ",") -> str:
    """A RAPID orient [q1,q2,q3,q4] of T's rotation (4, 4): the scalar-first unit quaternion
    to 8 decimals with q1 >= 0, trailing zeros dropped."""
    q = Rotation.from_matrix(T[:3, :3]).as_quat(scalar_first=True)
    q = q if q[0] >= 0 else -q
    return f"[{separator.join(_format(v, 8) for v in q)}]"


def pose_text(T: np.ndarray, separator: str = ",") -> str:
    """A RAPID pose [[x,y,z],[q1,q2,q3,q4]] of T (4, 4) [m]: mm to 4 decimals, the
    scalar-first unit quaternion to 8 decimals with q1 >= 0, trailing zeros dropped."""
    return f"[{position_text(T, separator)}{separator}{orientation_text(T, separator)}]"


def separator_of(text: str) -> str:
    """The separator a RAPID aggregate as written uses: ", " if it has one, else ","."""
    return ", " if ", " in text else ","


def _check_transform(T: np.ndarray) -> np.ndarray:
    T = np.asarray(T, dtype=float)
    if T.shape != (4, 4) or not np.allclose(T[3], [0, 0, 0, 1]):
        raise ValueError(f"T_uframe_oframe must be a (4, 4) homogeneous transform, got {T}")
    R = T[:3, :3]
    if not np.allclose(R.T @ R, np.eye(3), atol=1e-6) or np.linalg.det(R) <= 0:
        raise ValueError("the rotation of T_uframe_oframe is not a proper rotation")
    return T


def with_oframe(module: RapidModule, wobj: str, T_uframe_oframe: np.ndarray) -> str:
    """The module's text with only the `oframe` of work object `wobj` replaced by
    T_uframe_oframe (4, 4) [m], written in mm and a scalar-first quaternion (see pose_text),
    with the separator the old oframe used (", " or ","). Every other character (names,
    order, comments, whitespace, line endings) is kept; a CONST wobjdata is edited too. Write
    the result back with the encoding the file was read with."""
    T = _check_transform(T_uframe_oframe)
    data = find_wobj(module, wobj)
    parser = Parser(module.text, module.label)
    parser.module()
    decl = next(
        d for d in parser.decls if d.routine is None and d.name.casefold() == data.name.casefold()
    )
    assert decl.value is not None and decl.value.kind == "agg"  # read_module checked it
    oframe = decl.value.items[4]
    old = module.text[oframe.start : oframe.end]
    new = pose_text(T, separator_of(old))
    return module.text[: oframe.start] + new + module.text[oframe.end :]
