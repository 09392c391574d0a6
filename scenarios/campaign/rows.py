"""The rows of a campaign's table, as read back from results.csv (strings), grouped and
unpacked for the report and the figures."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

CALIBRATION_GOAL = (0.67, 1.5)
"""Goal of the median measured / predicted TRE ratio."""
HARM_M = 1.0e-3
"""A run that goes on (complete, or an accepted match) with a target off by more than this
is harmed [m] (the skull job's goal); with a fault, the goal is none."""


def quantiles(x: np.ndarray) -> dict[str, float]:
    """Quantiles of the finite values of x (a ratio with no prediction is left out)."""
    x = x[np.isfinite(x)]
    if len(x) == 0:
        return {"n": 0, "median": math.nan, "q05": math.nan, "q25": math.nan, "q75": math.nan,
                "q95": math.nan, "max": math.nan}  # fmt: skip
    q = np.quantile(x, [0.05, 0.25, 0.5, 0.75, 0.95])
    return {"n": len(x), "median": float(q[2]), "q05": float(q[0]), "q25": float(q[1]),
            "q75": float(q[3]), "q95": float(q[4]), "max": float(x.max())}  # fmt: skip


def target_columns(rows: list[dict[str, str]], prefix: str, suffix: str) -> list[str]:
    """Per-target columns `<prefix><k><suffix>` present in the rows."""
    names = set().union(*(r.keys() for r in rows)) if rows else set()
    return sorted(
        (c for c in names if c.startswith(prefix) and c.endswith(suffix)),
        key=lambda c: int(c[len(prefix) : len(c) - len(suffix)]),
    )


def per_target(rows: list[dict[str, str]], prefix: str, suffix: str) -> np.ndarray:
    """All per-target values of the rows (every target of every row), flattened."""
    columns = target_columns(rows, prefix, suffix)
    return np.array(
        [float(r[c]) for r in rows for c in columns if r.get(c, "") not in ("", None)], dtype=float
    )


def group_rows(
    rows: list[dict[str, str]], keys: list[str]
) -> list[tuple[str, list[dict[str, str]]]]:
    """Rows grouped by their sweep values (`vary.<key>` columns), in sweep-point order."""
    groups: dict[str, list[dict[str, str]]] = {}
    for row in sorted(rows, key=lambda r: (int(r.get("point", 0) or 0), r["trial_id"])):
        label = ", ".join(f"{k}={row.get(f'vary.{k}', '')}" for k in keys) or "all"
        groups.setdefault(label, []).append(row)
    return list(groups.items())


def json_ready(value: Any) -> Any:
    """NaN becomes None (JSON has no NaN)."""
    if isinstance(value, dict):
        return {k: json_ready(v) for k, v in value.items()}
    if isinstance(value, list):
        return [json_ready(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value
