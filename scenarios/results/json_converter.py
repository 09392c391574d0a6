"""The project's one JSON converter: the typed results (frozen dataclasses) to the mappings
their files hold (`unstructure`) and back (`structure`), by a cattrs `Converter` configured
here.

Why cattrs: it works on the frozen dataclasses as they are (no base class, no change to the
types); structure and unstructure are separate and customisable per class; and it is well
kept (python-attrs).

What the converter does beyond cattrs' own handling of dataclasses, Optional and Literal:
numpy arrays are written as (nested) lists and read back as float arrays, numpy scalars as
Python numbers, tuples as lists; a mapping of the wrong shape raises the plain KeyError,
TypeError or ValueError that names the key (no detailed validation; cattrs' own error for a
value outside a Literal). A class whose JSON is
not the plain mapping of its fields registers its layout (`register_writer`,
`register_reader`, `register_layout`): a key renamed or left out (cattrs.gen's `override`),
a bound written as null when it is not finite and read back as inf (`unbounded_number`,
`unbounded_numbers`: the project's edge, scenarios.results.edge), derived values the file
carries but nothing reads back (`derived`), the order of the keys (`keys`), and the keys a
file may lack (`may_lack`: those older files lack, or the writer leaves out).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterable, Mapping
from typing import Any, TypeVar

import cattrs
import cattrs.errors
import numpy as np
from cattrs.gen import AttributeOverride, make_dict_structure_fn, make_dict_unstructure_fn, override

from scenarios.results.budget_result import ErrorBudget, TargetBudget
from scenarios.results.edge import JsonObject, finite_or_none, unbounded
from scenarios.results.evaluations import CalibrationFigures, CalibrationSummary, TargetEvaluation
from scenarios.results.events import FaultOutcome, SupervisionEvent
from scenarios.results.exported_result import ExportedRun
from scenarios.results.method_reports import MatchReport, MethodReport
from scenarios.results.run import (
    SCHEMA_VERSION,
    IncompleteRun,
    ResultsError,
    RunResult,
    check_schema,
)
from scenarios.results.scan_plan_result import ScanPlanSummary
from scenarios.results.verification_result import TargetCheck, TcpCheck, Verification

T = TypeVar("T")

converter = cattrs.Converter(detailed_validation=False, unstruct_collection_overrides={tuple: list})
converter.register_unstructure_hook(np.ndarray, lambda a: a.tolist())
converter.register_structure_hook(np.ndarray, lambda v, _: np.array(v, dtype=float))
converter.register_unstructure_hook_func(
    lambda t: isinstance(t, type) and issubclass(t, np.generic), lambda v: v.item()
)

Derived = Callable[[Any], Mapping[str, object]]
"""An object's derived values, by key: written beside its fields, never read back."""


def unstructure(value: object) -> Any:
    """The JSON value of `value` (a mapping for a dataclass): plain numbers, strings, lists
    and mappings, None for missing."""
    return converter.unstructure(value)


def structure(data: Any, cls: type[T]) -> T:
    """The `cls` that the JSON value `data` holds (KeyError, TypeError or ValueError if it
    holds none)."""
    return converter.structure(data, cls)


def unbounded_number(rename: str | None = None) -> AttributeOverride:
    """A bound: written as null where it is not finite, null read back as inf."""
    return override(
        rename=rename, unstruct_hook=finite_or_none, struct_hook=lambda v, _: unbounded(v)
    )


def unbounded_numbers(rename: str | None = None) -> AttributeOverride:
    """A tuple of bounds, each as `unbounded_number`."""
    return override(
        rename=rename,
        unstruct_hook=lambda values: [finite_or_none(v) for v in values],
        struct_hook=lambda values, _: tuple(unbounded(v) for v in values),
    )


def register_writer(
    cls: type,
    *,
    keys: str | None = None,
    derived: Derived | None = None,
    left_out: Callable[[Any], Iterable[str]] | None = None,
    **fields: AttributeOverride,
) -> None:
    """Write `cls` as its fields (each renamed, left out or converted by its override in
    `fields`) and the `derived` values, less the keys `left_out` names for the object, in
    the order of `keys` if given: the key names, separated by blanks, one of which may be
    `...`: every other key, in the order the fields and then the derived values come
    (without `...`, `keys` must name every key)."""
    overrides: dict[str, Any] = fields  # by field name (cattrs types them with its options)
    written: Callable[[Any], JsonObject] = make_dict_unstructure_fn(cls, converter, **overrides)
    order = None if keys is None else tuple(keys.split())

    def write(value: object) -> JsonObject:
        out = written(value)
        if derived is not None:
            out.update(derived(value))
        for key in () if left_out is None else left_out(value):
            del out[key]
        return out if order is None else _in_order(out, order)

    converter.register_unstructure_hook(cls, write)


def register_reader(
    cls: type,
    *,
    read: Callable[[JsonObject], JsonObject] | None = None,
    may_lack: Iterable[str] = (),
    **fields: AttributeOverride,
) -> None:
    """Read `cls` from its mapping: every key the writer writes (a field's name, or its
    rename in `fields`) must be there except those the file `may_lack` (keys older files
    lack, or that the writer leaves out when it has nothing: the field's default then). A
    field left out of the writing (`omit`) is read from the mapping that `read` makes of
    the file's (e.g. a pose written as two numbers), or is its default."""
    reading: dict[str, Any] = {
        name: override(rename=o.rename, struct_hook=o.struct_hook) for name, o in fields.items()
    }
    read_fields: Callable[[JsonObject, type], object] = make_dict_structure_fn(
        cls, converter, **reading
    )
    lack = set(may_lack)
    required = tuple(
        key
        for f in dataclasses.fields(cls)
        if not (o := fields.get(f.name, override())).omit
        and (key := o.rename or f.name) not in lack
    )

    def read_json(data: JsonObject, _: object) -> object:
        missing = next((key for key in required if key not in data), None)
        if missing is not None:
            raise KeyError(missing)
        return read_fields(data if read is None else read(data), cls)

    converter.register_structure_hook(cls, read_json)


def register_layout(
    cls: type,
    *,
    keys: str | None = None,
    derived: Derived | None = None,
    left_out: Callable[[Any], Iterable[str]] | None = None,
    read: Callable[[JsonObject], JsonObject] | None = None,
    may_lack: Iterable[str] = (),
    **fields: AttributeOverride,
) -> None:
    """`register_writer` and `register_reader` with the same `fields`."""
    register_writer(cls, keys=keys, derived=derived, left_out=left_out, **fields)
    register_reader(cls, read=read, may_lack=may_lack, **fields)


def _in_order(out: JsonObject, keys: tuple[str, ...]) -> JsonObject:
    rest = [k for k in out if k not in keys]
    order = [k for key in keys for k in (rest if key == "..." else (key,))]
    if len(order) != len(out):
        raise KeyError(f"keys {keys} do not name every key of {list(out)}")
    return {k: out[k] for k in order}


# -- results.json's records --------------------------------------------------------------------
register_reader(SupervisionEvent, may_lack=("reading", "limit"))
register_layout(
    FaultOutcome,
    left_out=lambda f: () if f.injected is not None else ("symptom", "target_move_m"),
    may_lack=("symptom", "target_move_m"),
)
#: An exported program's run that did not complete is written as its status and reason only,
#: a complete one without a reason.
_COMPLETE_ONLY = ("program", "compensation", "target_error_rms_m", "target_error_max_m", "targets")
register_layout(
    ExportedRun,
    left_out=lambda r: ("reason",) if r.status == "complete" else _COMPLETE_ONLY,
    may_lack=("reason", *_COMPLETE_ONLY),
)
register_layout(
    ScanPlanSummary,
    keys="... predicted_tre_m chosen",
    predicted_tre_max_m=unbounded_number(),
    predicted_tre_m=unbounded_numbers(),
)
register_layout(
    TargetEvaluation,
    p_true_base=override(rename="p_true_base_m"),
    p_achieved_base=override(rename="p_achieved_base_m"),
)
register_layout(CalibrationSummary, stiffness_nm_rad=unbounded_numbers())


def _calibration_json(c: CalibrationFigures) -> JsonObject:
    """results.json's "calibration": whether it ran, its summary's figures (if it ran), the
    TCP errors as tcp_error_<nominal|calibrated>_<mean|max>_m."""
    out: JsonObject = {"enabled": c.enabled}
    if c.summary is not None:
        out.update(unstructure(c.summary))
    for label, e in (("nominal", c.nominal), ("calibrated", c.calibrated)):
        if e is not None:
            out[f"tcp_error_{label}_mean_m"] = e.mean_m
            out[f"tcp_error_{label}_max_m"] = e.max_m
    return out


def _calibration_fields(data: JsonObject) -> JsonObject:
    """The fields of CalibrationFigures in results.json's "calibration"."""

    def error(label: str) -> JsonObject | None:
        mean = data.get(f"tcp_error_{label}_mean_m")
        return None if mean is None else {"mean_m": mean, "max_m": data[f"tcp_error_{label}_max_m"]}

    # the laser's latency is identified across the network only, a saved calibration given
    # and checked in some runs: earlier runs have no such key
    optional = ("laser_latency_s", "laser_latency_sigma_s", "given", "check")
    latency = {k: data.get(k) for k in optional}
    summary = data | latency if data["enabled"] else None
    return data | {
        "summary": summary,
        "nominal": error("nominal"),
        "calibrated": error("calibrated"),
    }


register_layout(
    CalibrationFigures,
    keys="enabled ... tcp_error_configurations",
    derived=_calibration_json,
    read=_calibration_fields,
    summary=override(omit=True),
    nominal=override(omit=True),
    calibrated=override(omit=True),
    configurations=override(rename="tcp_error_configurations"),
)
register_reader(MatchReport)


def _method_fields(data: JsonObject) -> JsonObject:
    """A method's report in results.json (its pose as two numbers) as MethodReport's fields
    (the method's name, its key in "methods", put in by the run's reader)."""
    rotation = data["rotation_error_deg"]
    pose = {"rotation_error_deg": rotation, "translation_error_m": data["translation_error_m"]}
    return data | {"pose": None if rotation is None else pose}


register_layout(
    MethodReport,
    keys="accepted reason rotation_error_deg translation_error_m targets predicted_tre_m "
    "target_error_rms_m target_error_max_m ...",
    derived=lambda r: {
        "rotation_error_deg": None if r.pose is None else r.pose.rotation_error_deg,
        "translation_error_m": None if r.pose is None else r.pose.translation_error_m,
        "target_error_rms_m": r.rms_m,
        "target_error_max_m": r.max_m,
    },
    read=_method_fields,
    may_lack=("ir_readings",),
    method=override(omit=True),
    pose=override(omit=True),
    predicted_tre_m=unbounded_numbers(),
    readings=override(rename="ir_readings", omit_if_default=True),
)
register_layout(
    TargetBudget,
    keys="name tre_m arm_m tool_m model_m sigma_m bound_m",
    derived=lambda b: {"sigma_m": b.sigma_m},
    tre_m=unbounded_number(),
    arm_m=unbounded_number(),
    tool_m=unbounded_number(),
    model_m=unbounded_number(),
    bound_m=unbounded_number(),
)
register_layout(
    ErrorBudget,
    keys="... targets",
    derived=lambda b: {
        "rms_bound_m": b.rms_bound_m,
        "max_bound_m": b.max_bound_m,
        "within_reach": b.within_reach,
        "risks": list(b.risks),
    },
)
register_layout(
    TargetCheck,
    keys="name moved_m uncertainty_m allowance_m resolved ...",
    derived=lambda c: {"resolved": c.resolved, "decision": c.decision},
    goal_m=unbounded_number(),
)
register_layout(
    Verification,
    keys="... targets",
    derived=lambda v: {
        "agrees": v.agrees,
        "resolved": v.resolved,
        "verified_to_m": None if not v.checks else v.verified_to_m,
    },
    checks=override(rename="targets"),
)


def _offset_read(value: list[float] | None, _: object) -> tuple[float, float]:
    """A tool's offset as results.json holds it: null where a sweep missed the beam (inf)."""
    x, y = (math.inf, math.inf) if value is None else value
    return float(x), float(y)


register_layout(
    TcpCheck,
    keys="tool offset_m off_m sigma_m tolerance_m resolves_m referenced attempt decision "
    "corrected ok",
    derived=lambda c: {
        "off_m": finite_or_none(c.off_m),
        "resolves_m": c.resolves_m,
        "decision": c.decision,
        "corrected": c.corrected,
        "ok": c.ok,
    },
    offset_m=override(
        unstruct_hook=lambda o: list(o) if all(math.isfinite(v) for v in o) else None,
        struct_hook=_offset_read,
    ),
)


# -- the run: results.json ------------------------------------------------------------------------
def _registration_json(r: RunResult) -> JsonObject:
    """results.json's "registration": the driving method, the match's figures, and the
    surface pose's error against the truth."""
    out: JsonObject = {"method": r.primary.method, "verdict": "rejected"}
    if r.match is not None:
        out.update(unstructure(r.match))
    surface = r.method("surface")
    if surface is not None and surface.pose is not None:
        out.update(
            rotation_error_deg=surface.pose.rotation_error_deg,
            translation_error_m=surface.pose.translation_error_m,
        )
    if surface is not None and not surface.accepted:
        out.setdefault("reason", surface.reason)
    return out


def _run_derived(r: RunResult) -> JsonObject:
    """What results.json says of a run beside its fields: the registration section, and the
    driving method's targets (each with its predicted TRE) and their errors."""
    primary = r.primary
    return {
        "registration": _registration_json(r),
        "targets": [
            {**unstructure(t), "predicted_tre_m": primary.predicted(t.name)}
            for t in primary.targets
        ],
        "target_error_rms_m": r.target_error_rms_m,
        "target_error_max_m": r.target_error_max_m,
    }


def _run_fields(data: JsonObject) -> JsonObject:
    """The match, a field of RunResult, from results.json's "registration" (where the match
    ran: its figures are there)."""
    registration = data["registration"]
    return data | {"match": registration if "rms_m" in registration else None}


register_layout(
    RunResult,
    keys="schema_version status reason job seed model scan_points registration methods targets "
    "target_error_rms_m target_error_max_m ...",
    derived=_run_derived,
    read=_run_fields,
    # Keys that files of schema 1 written before the arm's window, the plan cache, the
    # verification, the tools' checks, the cell's clock and the error budget lack.
    may_lack=(
        "home_deg",
        "limits_deg",
        "plan_cache",
        "verifications",
        "tool_checks",
        "cell_time_s",
        "budget",
    ),
    match=override(omit=True),
    methods=override(
        unstruct_hook=lambda methods: {r.method: unstructure(r) for r in methods},
        struct_hook=lambda data, _: tuple(
            structure({"method": name, **d}, MethodReport) for name, d in data.items()
        ),
    ),
    timings=override(rename="timings_s"),
)
_read_run_fields = converter.get_structure_hook(RunResult)


def _read_run(data: JsonObject, _: object) -> RunResult:
    """A finished cell job's result of this schema; ResultsError naming what is missing or
    bad (RunNotEndedError for a run that did not end)."""
    check_schema(data)
    try:
        return _read_run_fields(data, RunResult)
    except (KeyError, TypeError, ValueError, cattrs.errors.CattrsError) as exc:
        raise ResultsError(
            f"results.json (schema {SCHEMA_VERSION}) of job {data.get('job')!r}: missing or "
            f"bad {exc}"
        ) from None


converter.register_structure_hook(RunResult, _read_run)
register_writer(
    IncompleteRun,
    keys="schema_version status reason job seed stage seconds",
    derived=lambda _: {"schema_version": SCHEMA_VERSION},
)
