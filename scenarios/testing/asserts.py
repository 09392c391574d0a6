"""What a test states of a run, each failing with what failed: which goal or target, by how
much, against which limit, at which seed, and the run folder with the command to look at it.
"""

from __future__ import annotations

from collections.abc import Iterable

from scenarios.results.exported_result import ExportedRun
from scenarios.results.run import RunResult
from scenarios.testing.runs import JobRun


def _mm(value_m: float | None) -> str:
    return "-" if value_m is None else f"{value_m * 1e3:.3f} mm"


def _fail(run: JobRun, what: str, lines: Iterable[str]) -> AssertionError:
    body = "\n".join(f"  {line}" for line in lines)
    return AssertionError(f"twincell: {run.title()}: {what}\n{body}\n  {run.look}")


def _targets(run: JobRun) -> list[str]:
    return [f"{t.name}: {_mm(t.error_m)}" for t in run.result.targets]


def assert_goals(run: JobRun) -> None:
    """The run's program ran to its end ("complete", or "at_risk": the job could not promise
    its goals, which the truth then decides) and met the job's goals (its target RMS and
    worst target); and the program it exported, where the job ran it on the real cell as a
    controller without absolute accuracy does (results.json's `exported_program`, the run
    table's program.mod row), ran to its end and met the same goals."""
    __tracebackhide__ = True
    r = run.result
    if r.status not in ("complete", "at_risk"):
        raise _fail(run, f"the run ended {r.status} in {r.stage or 'the job'}", [str(r.reason)])
    exported = r.exported_program
    if exported is not None and exported.status != "complete":
        raise _fail(
            run,
            f"the exported program {r.program_file} ended {exported.status} on the real cell",
            [exported.reason],
        )
    values = {
        "target_error_rms_m": r.target_error_rms_m,
        "target_error_max_m": r.target_error_max_m,
    }
    missed = [
        f"{name}: {_mm(values.get(name))} > goal {_mm(check.limit_m)}"
        for name, check in r.checks.items()
        if not check.met
    ]
    if missed:
        raise _fail(run, "the goals are not met", [*missed, "targets: " + ", ".join(_targets(run))])
    if exported is not None:
        _hold_exported(run, exported)


def _hold_exported(run: JobRun, exported: ExportedRun) -> None:
    """The exported program's figures against the job's goals (None: it touched none of the
    job's targets, a miss)."""
    __tracebackhide__ = True
    values = {
        "target_error_rms_m": ("RMS", exported.target_error_rms_m),
        "target_error_max_m": ("max", exported.target_error_max_m),
    }
    missed = [
        f"exported program {label}: {_mm(value)} > goal {name} {_mm(check.limit_m)}"
        for name, check in run.result.checks.items()
        if name in values
        for label, value in [values[name]]
        if value is None or value > check.limit_m
    ]
    if missed:
        touched = ", ".join(f"{t.name}: {_mm(t.error_m)}" for t in exported.targets) or "none"
        raise _fail(
            run,
            f"the exported program {run.result.program_file} ({exported.compensation} "
            "compensation) missed the goals on the real cell, run by a controller without "
            "absolute accuracy",
            [*missed, f"its targets: {touched}", _achieved(run.result)],
        )


def _achieved(r: RunResult) -> str:
    """The job's own execution's figures, which met the goals."""
    rms, worst = _mm(r.target_error_rms_m), _mm(r.target_error_max_m)
    return f"the job's own execution met them: RMS {rms}, max {worst}"


def assert_targets_within(
    run: JobRun, tolerance_m: float, targets: Iterable[str] | None = None
) -> None:
    """Every target (or those named) was reached within `tolerance_m` [m] of its true place."""
    __tracebackhide__ = True
    r = run.result
    if r.status not in ("complete", "at_risk"):
        raise _fail(run, f"the run ended {r.status} in {r.stage or 'the job'}", [str(r.reason)])
    wanted = None if targets is None else set(targets)
    reached = [t for t in r.targets if wanted is None or t.name in wanted]
    if wanted is not None and (unknown := wanted - {t.name for t in reached}):
        names = ", ".join(t.name for t in r.targets) or "none"
        raise _fail(run, f"no target {', '.join(sorted(unknown))}", [f"the run's targets: {names}"])
    if not reached:
        raise _fail(run, "no target was reached", ["the run touched none of the job's targets"])
    beyond = [t for t in reached if t.error_m > tolerance_m]
    if beyond:
        lines = [f"{t.name}: {_mm(t.error_m)} > {_mm(tolerance_m)}" for t in beyond]
        raise _fail(
            run, f"{len(beyond)} of {len(reached)} targets beyond {_mm(tolerance_m)}", lines
        )


def assert_detected(run: JobRun, fault: str) -> None:
    """The fault `fault` (a kind of `--list-faults`) was injected and the cell detected it
    (a check or the supervision), rather than completing the job unaware."""
    __tracebackhide__ = True
    outcomes = [f for f in run.result.faults if f.name == fault]
    if not outcomes:
        injected = ", ".join(f.name for f in run.result.faults) or "none"
        raise _fail(run, f"no fault {fault} in the run", [f"its faults: {injected}"])
    missed = [f for f in outcomes if f.detected_by in ("missed", "not injected")]
    if missed:
        lines = [f"{f.name} = {f.amount:g}: {f.detected_by}" for f in missed]
        lines.append(f"the run ended {run.result.status}: {run.result.reason or 'no reason given'}")
        raise _fail(run, f"the {fault} went undetected", lines)
