"""How the link to a controller fails, as the job sees it."""

from __future__ import annotations

from cell.cell_errors import CellError, SupervisionError


class LinkError(SupervisionError):
    """The link to the controller failed where the job cannot go on safely: its position
    stream stale, its Robot Web Services not answering, a program that did not end. Like a
    supervision stop, it ends the job where it is (nothing more is commanded); the message
    says where and what was waited for."""

    def __init__(self, message: str) -> None:
        super().__init__("link", message)


class ControllerRefusalError(CellError, RuntimeError):
    """The controller refused or could not run what the client asked (a move its planner
    refuses, a move that failed on the cell); the message is the controller's, with the
    event log's entry."""


class NotOfferedError(CellError, NotImplementedError):
    """A command of the controller API that this client does not offer over the controller's
    interfaces; the message names it and what to use instead."""
