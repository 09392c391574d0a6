"""Exceptions of the scenarios package, and the errors a user can fix."""

from __future__ import annotations

import sys


class ScenarioError(Exception):
    """Root of every error raised by `scenarios`."""


def user_errors() -> tuple[type[BaseException], ...]:
    """The root exceptions of the project's packages: bad input a user can fix (one line,
    not a traceback). Only those of the packages imported by now: the others cannot have
    raised (importing the cell to check would cost a register call a second)."""
    errors: list[type[BaseException]] = [ScenarioError]
    if "registration.registration_errors" in sys.modules:
        from registration.registration_errors import RegistrationError

        errors.append(RegistrationError)
    if "cell.cell_errors" in sys.modules:
        from cell.cell_errors import CellError, SupervisionError

        errors += [CellError, SupervisionError]
    if "models.model_errors" in sys.modules:
        from models.model_errors import ModelError

        errors.append(ModelError)
    return tuple(errors)
