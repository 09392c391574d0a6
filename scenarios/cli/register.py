"""`twincell register DATA MODEL`: surface matching of files, printed and written as JSON."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from registration import MODES, InputError, MatchResult, load_model, load_points, match
from registration.io import load_targets
from registration.matcher import is_mode
from scenarios.outputs.run_folder import write_json
from scenarios.results.edge import JsonObject


@dataclass(frozen=True)
class Targets:
    """Named target points (K, 3) in the model frame [m]."""

    names: tuple[str, ...]
    points: np.ndarray


def load_named_targets(path: str | Path, units: str) -> Targets:
    """The targets of a file (see registration.io.load_targets) with their names."""
    names, points = load_targets(path, units)
    return Targets(names, points)


def register_files(
    data_path: str,
    model_path: str,
    mode: str = "auto",
    units: str = "m",
    model_units: str | None = None,
    seed: int = 0,
    targets: Targets | None = None,
    noise_m: float | None = None,
    T_init: np.ndarray | None = None,
) -> MatchResult:
    """Load the data points and the model (in their units), and match them; T_init (4, 4)
    [m] is a guess of T_model_data (needed by mode "refine", one more start in the others)."""
    if not is_mode(mode):
        raise InputError(f"unknown mode {mode!r}; valid: {', '.join(MODES)}")
    if mode == "refine" and T_init is None:
        raise InputError("mode 'refine' starts from a guess: give it with --init FILE")
    data = load_points(data_path, units)
    model = load_model(model_path, model_units or units)
    try:
        return match(
            data,
            model,
            mode=mode,
            T_init=T_init,
            seed=seed,
            targets=None if targets is None else targets.points,
            noise=noise_m,
        )
    except InputError as exc:
        if "same units" in str(exc):
            raise InputError(f"{data_path} against {model_path}: {exc}") from None
        raise


def result_dict(result: MatchResult, targets: Targets | None = None) -> JsonObject:
    """The JSON form of a result; T_model_data maps data coordinates into model coordinates
    (lengths in metres)."""
    out: JsonObject = {
        "T_model_data": result.T_model_data,
        "rotation": result.rotation,
        "translation": result.translation,
        "rms": result.rms,
        "inlier_fraction": result.inlier_fraction,
        "ambiguity": result.ambiguity,
        "worst_predicted_tre": result.worst_predicted_tre,
        "floor": result.floor,
        "symmetries": [s.name for s in result.symmetries],
        "equivalent_poses": list(result.equivalent_poses),
        "iterations": result.iterations,
        "starts": result.starts,
        "points_used": result.points_used,
        "mode": result.mode,
        "seed": result.seed,
        "seconds": result.seconds,
        "verdict": result.verdict,
        "reason": result.reason,
    }
    if targets is not None and result.targets is not None:
        t = result.targets
        out["targets"] = [
            {
                "name": name,
                "point": point,
                "predicted_tre": tre,
                "verdict": verdict,
                "moved_by": moved,
                "reason": reason,
            }
            for name, point, tre, verdict, moved, reason in zip(
                targets.names, targets.points, t.tre, t.verdict, t.moved_by, t.reason,
                strict=True,
            )
        ]  # fmt: skip
    return out


def write_result_json(
    result: MatchResult, path: str | Path, targets: Targets | None = None
) -> Path:
    return write_json(Path(path), result_dict(result, targets))


def render_result(result: MatchResult, targets: Targets | None = None) -> None:
    """Print the transform and the quality figures as a table."""
    from rich.console import Console
    from rich.table import Table
    from rich.text import Text

    console = Console()
    T = np.array2string(result.T_model_data, precision=6, suppress_small=True)
    console.print("T_model_data (maps data coordinates into model coordinates, metres):")
    console.print(T)
    table = Table(show_header=False)
    table.add_column("figure", style="bold")
    table.add_column("value")
    rows = [
        ("rms [mm]", f"{result.rms * 1e3:.4g}"),
        ("inlier fraction", f"{result.inlier_fraction:.3f}"),
        ("ambiguity", f"{result.ambiguity:.3f}"),
        ("worst predicted TRE [mm]", f"{result.worst_predicted_tre * 1e3:.4g}"),
        ("symmetries", "; ".join(s.name for s in result.symmetries) or "none"),
        ("starts / points used", f"{result.starts} / {result.points_used}"),
        ("mode, seed", f"{result.mode}, {result.seed}"),
        ("seconds", f"{result.seconds:.3f}"),
        ("verdict", f"{result.verdict}: {result.reason}"),
    ]
    for label, value in rows:
        table.add_row(Text(label), Text(value))
    console.print(table)
    if targets is not None and result.targets is not None:
        per = Table(title="targets")
        for column in ("target", "predicted TRE [mm]", "verdict", "why"):
            per.add_column(column)
        t = result.targets
        for name, tre, verdict, reason in zip(
            targets.names, t.tre, t.verdict, t.reason, strict=True
        ):
            per.add_row(Text(name), f"{tre * 1e3:.4g}", verdict, Text(reason))
        console.print(per)
