"""The errors a user can fix are told from the rest by name (scenarios.scenario_errors): each
name is a real exception class of the project, an error derived from one is a user error, and
other exceptions are not."""

from __future__ import annotations

import importlib

import pytest

from scenarios.scenario_errors import USER_ERROR_ROOTS, is_user_error


@pytest.mark.parametrize("name", sorted(USER_ERROR_ROOTS))
def test_each_root_is_a_class_and_its_subclasses_are_user_errors(name: str) -> None:
    module, _, qualname = name.rpartition(".")
    root = getattr(importlib.import_module(module), qualname)
    assert isinstance(root, type) and issubclass(root, BaseException)

    class Derived(root):  # type: ignore[valid-type, misc]
        """An error of the project's own kind, as a package would derive it."""

    error = Derived.__new__(Derived)  # whatever its own arguments are
    assert is_user_error(error)


def test_other_errors_are_not_user_errors() -> None:
    assert not is_user_error(ValueError("a bug"))
    assert not is_user_error(KeyError("a bug"))
    assert not is_user_error(RuntimeError("a bug"))
