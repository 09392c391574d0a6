"""Exceptions of the scenarios package, and the errors a user can fix."""

from __future__ import annotations


class ScenarioError(Exception):
    """Root of every error raised by `scenarios`."""


#: The root exceptions of the project's packages, by module and name: bad input a user can
#: fix (one line, not a traceback). Named, not imported, so that telling an error costs no
#: import of the packages it did not come from (the cell's costs a register call a second).
USER_ERROR_ROOTS = frozenset(
    {
        "scenarios.scenario_errors.ScenarioError",
        "registration.registration_errors.RegistrationError",
        "cell.cell_errors.CellError",
        "cell.cell_errors.SupervisionError",
        "models.model_errors.ModelError",
    }
)


def is_user_error(exc: BaseException) -> bool:
    """Whether `exc` derives from one of the project's user errors (USER_ERROR_ROOTS)."""
    return any(f"{c.__module__}.{c.__qualname__}" in USER_ERROR_ROOTS for c in type(exc).__mro__)
