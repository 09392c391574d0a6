"""`twincell register DATA... MODEL` and `twincell prepare MODEL`: surface matching of files,
printed and written as JSON (one scan) or as JSON Lines (a batch: one line per scan, a scan
that fails is a line with its error).

Imports only what a match needs (numpy, scipy, libigl, the registration package, typer and
rich for the output): no simulation, no job configuration, no recording.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, TextIO

import numpy as np

from registration import (
    MODES,
    InputError,
    MatchResult,
    MeshModel,
    RegistrationError,
    Shape,
    load_model,
    load_points,
    match,
)
from registration.io import load_targets
from registration.match_request import Mode, is_mode
from registration.prepared import (
    ModelSource,
    check_target,
    is_prepared_file,
    load_prepared,
    read_source,
    save_prepared,
)
from registration.symmetry import symmetry_cache
from scenarios.outputs.run_folder import write_json

if TYPE_CHECKING:
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


@dataclass(frozen=True)
class MatchOptions:
    """How every scan of one call is matched: the mode, the data's units ("m" or "mm"), the
    seed, the targets, the sensor noise [m] (None: from the data) and a guess T_model_data
    (4, 4) [m] (needed by mode "refine", one more start in the others)."""

    mode: str = "auto"
    units: str = "m"
    seed: int = 0
    targets: Targets | None = None
    noise_m: float | None = None
    T_init: np.ndarray | None = None

    def check(self) -> Mode:
        """The mode, checked: an unknown mode, and mode "refine" without a guess, are
        refused."""
        mode = self.mode
        if not is_mode(mode):
            raise InputError(f"unknown mode {mode!r}; valid: {', '.join(MODES)}")
        if mode == "refine" and self.T_init is None:
            raise InputError("mode 'refine' starts from a guess: give it with --init FILE")
        return mode


def model_units_of(path: str, units: str, model_units: str | None = None) -> str:
    """The units the model's targets are given in: `model_units`, else those a prepared
    model (.twm) was prepared in, else `units`."""
    if model_units is not None:
        return model_units
    return read_source(path).units if is_prepared_file(path) else units


def load_model_file(path: str, units: str, model_units: str | None = None) -> Shape:
    """The model of a mesh or point file in `model_units` (else `units`), or of a prepared
    model (.twm), whose units are those it was prepared in: an explicit `model_units` that
    disagrees with them is refused."""
    if not is_prepared_file(path):
        return load_model(path, model_units or units)
    prepared = load_prepared(path)
    stored = prepared.source.units
    if model_units is not None and model_units != stored:
        raise InputError(
            f"{path} was prepared from a model in {stored} ({prepared.source.path}), but "
            f"--model-units says {model_units}: leave --model-units out (a prepared model "
            f"knows its units) or prepare it again with --units {model_units}"
        )
    return prepared.shape


def match_points(
    data: np.ndarray, model: Shape, options: MatchOptions, data_path: str, model_path: str
) -> MatchResult:
    """Match data points (N, 3) [m] to the model with `options`; the files' names go into a
    units error."""
    mode, targets = options.check(), options.targets
    try:
        return match(
            data,
            model,
            mode=mode,
            T_init=options.T_init,
            seed=options.seed,
            targets=None if targets is None else targets.points,
            noise=options.noise_m,
        )
    except InputError as exc:
        if "same units" in str(exc):
            raise InputError(f"{data_path} against {model_path}: {exc}") from None
        raise


def register_files(
    data_path: str, model_path: str, options: MatchOptions, model_units: str | None = None
) -> MatchResult:
    """Load the data points (in options.units) and the model (a file in `model_units`, else
    options.units, or a prepared .twm), and match them."""
    options.check()
    data = load_points(data_path, options.units)
    model = load_model_file(model_path, options.units, model_units)
    return match_points(data, model, options, data_path, model_path)


@dataclass(frozen=True)
class ScanOutcome:
    """One scan of a batch: its result, or the one-line error that stopped it (`internal`:
    an error of the program, not of the input)."""

    data: str
    result: MatchResult | None = None
    error: str | None = None
    internal: bool = False


def register_batch(
    data_paths: list[str], model: Shape, model_path: str, options: MatchOptions
) -> Iterator[ScanOutcome]:
    """Match every data file against one model, in order; a scan that fails gives its error
    and the next one runs."""
    options.check()
    for data_path in data_paths:
        try:
            data = load_points(data_path, options.units)
            result = match_points(data, model, options, data_path, model_path)
        except RegistrationError as exc:
            yield ScanOutcome(data_path, error=str(exc))
        except Exception as exc:  # a bug shown on its scan's line; the batch goes on
            message = f"internal error ({type(exc).__name__}): {exc}"
            yield ScanOutcome(data_path, error=message, internal=True)
        else:
            yield ScanOutcome(data_path, result=result)


def prepare_file(model_path: str, out: str | None, units: str) -> tuple[Path, Shape]:
    """Read a model file in `units`, prepare it and write it to `out` (default: beside the
    model, with the suffix .twm)."""
    if is_prepared_file(model_path):
        raise InputError(f"{model_path} is already a prepared model; give the model file")
    target = check_target(out if out is not None else Path(model_path).with_suffix(".twm"))
    shape = load_model(model_path, units)
    written = save_prepared(shape, target, ModelSource.of(model_path, units))
    return written, shape


def model_summary(shape: Shape) -> str:
    """The model in words: its kind and size, and its symmetries."""
    if isinstance(shape, MeshModel):
        kind = f"a mesh of {len(shape.vertices)} vertices and {len(shape.faces)} faces"
    else:
        kind = f"{len(shape.samples)} model points"
    found = {s.name for symmetries in symmetry_cache(shape).values() for s in symmetries}
    return f"{kind}, symmetries: {'; '.join(sorted(found)) or 'none'}"


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


def _plain(value: object) -> object:
    """A JSON value: arrays and numpy scalars as lists and numbers, NaN and inf as null (as
    write_json writes them)."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return _plain(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def outcome_line(outcome: ScanOutcome, model_path: str, targets: Targets | None) -> str:
    """The JSON Lines line of one scan of a batch: its data and model files, and its result's
    fields (as `--json` writes them for one scan) or its error."""
    head: dict[str, object] = {"data": outcome.data, "model": model_path}
    if outcome.result is None:
        body: dict[str, object] = {"error": outcome.error, "internal": outcome.internal}
    else:
        body = dict(result_dict(outcome.result, targets))
    return json.dumps(_plain(head | body))


def summary_line(outcome: ScanOutcome) -> str:
    """One line for a person: the scan's verdict, RMS and time, or its error."""
    r = outcome.result
    if r is None:
        return f"{outcome.data}: error: {outcome.error}"
    return f"{outcome.data}: {r.verdict}, rms {r.rms * 1e3:.4g} mm, {r.seconds:.3f} s"


@dataclass(frozen=True)
class BatchCount:
    """How a batch went: scans matched, failed on their input, failed by an internal error."""

    matched: int
    failed: int
    internal: int


def write_batch(
    outcomes: Iterator[ScanOutcome],
    model_path: str,
    targets: Targets | None,
    lines: TextIO,
    progress: Callable[[str], None] | None = None,
) -> BatchCount:
    """Write each scan's line to `lines` as it finishes (flushed: a long batch can be
    followed), and its summary to `progress` if given."""
    matched = failed = internal = 0
    for outcome in outcomes:
        lines.write(outcome_line(outcome, model_path, targets) + "\n")
        lines.flush()
        if progress is not None:
            progress(summary_line(outcome))
        matched += outcome.result is not None
        failed += outcome.result is None and not outcome.internal
        internal += outcome.internal
    return BatchCount(matched, failed, internal)


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
