"""Exceptions of the registration package: one root, subclasses that are also built-ins."""

from __future__ import annotations


class RegistrationError(Exception):
    """Root of every error raised by `registration`."""


class InputError(RegistrationError, ValueError):
    """Bad input: the message says what was given and what is valid."""


class FormatError(InputError):
    """A file that cannot be read as points or a mesh."""


def first_line(exc: BaseException) -> str:
    """The first line of an exception's message (libraries append multi-line reports)."""
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__
