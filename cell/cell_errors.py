"""Exceptions of the cell package.

Every error a user (or a planner) can cause is a `CellError`; the subclasses also inherit the
matching built-in exception so that callers may catch either.
"""

from __future__ import annotations


class CellError(Exception):
    """Root of every error raised by `cell`."""


class CellConfigError(CellError, ValueError):
    """A configuration value outside its valid range (noise, sizes, poses, counts)."""


class UnreachableTargetError(CellError, ValueError):
    """A pose the arm cannot reach within its joint limits; the message gives the residual."""


class JointLimitError(CellError, ValueError):
    """A joint target outside the joint limits; the message names the joint and the limits."""


class UnknownNameError(CellError, LookupError):
    """An unknown tool or frame name; the message lists the valid names."""

    def __str__(self) -> str:  # LookupError would quote the message like a dict key
        return str(self.args[0]) if self.args else ""


class ToolChangerError(CellError, RuntimeError):
    """A tool-changer command that cannot be done in the current state (already holding...)."""


class SupervisionError(RuntimeError):
    """The controller's supervision stopped the cell (a collision, a tool not locked, the
    table not in position, an implausible reading, a load that does not match its
    tooldata); the arm stands backed off and still. `code` names the supervision. Not a
    CellError: code that turns a move the arm cannot make into a planning error lets a stop
    pass, to the job that ends there."""

    def __init__(self, code: str, message: str) -> None:
        super().__init__(message)
        self.code = code


class MotionHaltedError(CellError, RuntimeError):
    """A move halted where it was by a stop asked from outside the program (a served
    controller's stop request); the arm stands still on its path. Starting again runs the
    interrupted move from there."""
