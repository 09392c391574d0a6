"""`twincell register DATA MODEL`: surface matching of files, printed and written as JSON."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from registration import MODES, InputError, MatchResult, match
from registration.io import load_model, load_points
from scenarios.run_folder import write_json


def register_files(data_path: str, model_path: str, mode: str) -> MatchResult:
    """Load the data points and the model, and match them in the given mode."""
    if mode not in MODES or mode == "refine":
        valid = ", ".join(m for m in MODES if m != "refine")
        raise InputError(
            f"mode {mode!r} is not available from files (refine needs an initial pose); "
            f"valid: {valid}"
        )
    data = load_points(data_path)
    model = load_model(model_path)
    return match(data, model, mode=mode)  # type: ignore[arg-type]


def result_dict(result: MatchResult) -> dict[str, Any]:
    """The JSON form of a result; T_model_data maps data coordinates into model coordinates."""
    return {
        "T_model_data": result.T_model_data,
        "rotation": result.rotation,
        "translation": result.translation,
        "rms": result.rms,
        "inlier_fraction": result.inlier_fraction,
        "ambiguity": result.ambiguity,
        "iterations": result.iterations,
        "starts": result.starts,
        "seconds": result.seconds,
        "verdict": result.verdict,
        "reason": result.reason,
    }


def write_result_json(result: MatchResult, path: str | Path) -> Path:
    return write_json(Path(path), result_dict(result))


def render_result(result: MatchResult) -> None:
    """Print the transform and the quality figures as a table."""
    from rich.console import Console
    from rich.table import Table

    console = Console()
    T = np.array2string(result.T_model_data, precision=6, suppress_small=True)
    console.print("T_model_data (maps data coordinates into model coordinates):")
    console.print(T)
    table = Table(show_header=False)
    table.add_column("figure", style="bold")
    table.add_column("value")
    rows = [
        ("rms", f"{result.rms:.6g}"),
        ("inlier fraction", f"{result.inlier_fraction:.3f}"),
        ("ambiguity", f"{result.ambiguity:.3f}"),
        ("iterations", str(result.iterations)),
        ("starts", str(result.starts)),
        ("seconds", f"{result.seconds:.3f}"),
        ("verdict", f"{result.verdict}: {result.reason}"),
    ]
    for label, value in rows:
        table.add_row(label, value)
    console.print(table)
