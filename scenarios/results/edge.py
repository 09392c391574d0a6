"""The project's file edge: a mapping as a JSON or YAML file holds it (results.json, a
trial's row, a configuration and its overrides, the register command's JSON). Only the code
that reads or writes such a file handles one; everything between is typed."""

import math
from typing import Any

JsonObject = dict[str, Any]
"""A JSON or YAML object, as read from a file or about to be written to one."""


def unbounded(value: float | None) -> float:
    """A bound read back from a file: null (how a non-finite number is written, e.g. the
    predicted TRE of a target no pass constrains, or a joint not modelled as compliant) is
    inf."""
    return float("inf") if value is None else float(value)


def finite_or_none(value: float) -> float | None:
    """A bound as a file holds it: a non-finite number is null (read back as inf by
    `unbounded`)."""
    return value if math.isfinite(value) else None
