"""The errors a served controller answers with, as RWS answers them: an HTTP status, a
negative code and a message."""

from __future__ import annotations

from scenarios.scenario_errors import ScenarioError

#: The codes of the twin's RWS errors (HRESULT-like, as RWS 1.0 gives them; the twin's own
#: numbering, since ABB does not publish one table of them).
CODES = {
    "bad_request": -1073445865,
    "not_found": -1073445860,
    "forbidden": -1073445862,
    "not_allowed": -1073445857,
    "too_large": -1073445856,
    "rapid": -1073445851,
    "busy": -1073445848,
}


class ControllerError(ScenarioError, RuntimeError):
    """A request the served controller refuses: `status` (HTTP), `kind` (a key of CODES)
    and the message a client shows."""

    def __init__(self, status: int, kind: str, message: str) -> None:
        super().__init__(message)
        self.status = status
        self.kind = kind

    @property
    def code(self) -> int:
        return CODES[self.kind]


def bad_request(message: str) -> ControllerError:
    return ControllerError(400, "bad_request", message)


def not_found(message: str) -> ControllerError:
    return ControllerError(404, "not_found", message)


def forbidden(message: str) -> ControllerError:
    return ControllerError(403, "forbidden", message)


def not_allowed(message: str) -> ControllerError:
    """A request the controller's state does not allow now (motors off, a program running)."""
    return ControllerError(409, "not_allowed", message)
