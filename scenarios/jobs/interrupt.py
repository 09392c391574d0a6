"""A run stopped by SIGINT or SIGTERM: the signal becomes an exception, so that the stack
unwinds through every cleanup (the recording discarded, results.json written "incomplete")
and nothing more is commanded to the cell.

    >>> with SignalGuard() as guard:   # in the main thread
    ...     try:
    ...         work()                  # SIGTERM here raises RunInterrupted("SIGTERM")
    ...     except BaseException:
    ...         guard.hold()            # the wind-down is not interrupted again
    ...         clean_up()
    ...         raise
"""

from __future__ import annotations

import signal
import threading
from types import FrameType, TracebackType
from typing import Any

SIGNALS = (signal.SIGINT, signal.SIGTERM)


class RunInterrupted(BaseException):
    """A run stopped by a signal (`signal_name`: "SIGINT" or "SIGTERM").

    A BaseException, as KeyboardInterrupt is: no `except Exception` on the way up swallows
    it, and every `finally` runs. The runner fills in the `stage` the run was in and its run
    `folder`; `exit_status` is the shell's 128 + the signal's number (130, 143)."""

    def __init__(
        self, signal_name: str, stage: str | None = None, folder: str | None = None
    ) -> None:
        if signal_name not in {s.name for s in SIGNALS}:
            raise ValueError(
                f"unknown signal {signal_name!r}; valid: {', '.join(s.name for s in SIGNALS)}"
            )
        super().__init__(signal_name, stage, folder)
        self.signal_name = signal_name
        self.stage = stage
        self.folder = folder

    def __reduce__(self) -> tuple[Any, ...]:  # the stage and folder a runner filled in too
        return (type(self), (self.signal_name, self.stage, self.folder))

    @property
    def reason(self) -> str:
        """As results.json says it: "interrupted (SIGTERM)"."""
        return f"interrupted ({self.signal_name})"

    @property
    def exit_status(self) -> int:
        """The exit status of a command stopped by this signal: 130 (SIGINT), 143 (SIGTERM)."""
        return 128 + int(signal.Signals[self.signal_name])

    def __str__(self) -> str:
        where = "" if self.stage is None else f" during {self.stage}"
        folder = "" if self.folder is None else f"; run folder {self.folder}"
        return f"{self.reason}{where}{folder}"


class SignalGuard:
    """While entered in the main thread, the first SIGINT or SIGTERM raises RunInterrupted
    there; later ones, and any after `hold()`, are noted in `received` and otherwise
    ignored, so that the run winds down (or finishes) undisturbed. On exit the previous
    handlers are back. Elsewhere than in the main thread (a Dask worker's thread) it does
    nothing: Python delivers signals to the main thread only. A signal that whoever started
    the process ignores (SIG_IGN: `nohup`, a shell's background job) stays ignored."""

    def __init__(self) -> None:
        self.received: str | None = None
        self._armed = False
        self._previous: dict[signal.Signals, Any] = {}

    def __enter__(self) -> SignalGuard:
        if threading.current_thread() is threading.main_thread():
            for sig in SIGNALS:
                previous = signal.getsignal(sig)
                if previous == signal.SIG_IGN:
                    continue
                self._previous[sig] = previous
                signal.signal(sig, self._handle)
            self._armed = True
        return self

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        name = signal.Signals(signum).name
        if self.received is None:
            self.received = name
        if self._armed:
            self._armed = False
            raise RunInterrupted(name)

    def hold(self) -> None:
        """From now on a signal is noted, not raised: the run is winding down or done."""
        self._armed = False

    def __exit__(
        self,
        kind: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self._armed = False
        for sig, previous in self._previous.items():
            # None: a handler not set from Python; the default is the nearest we can restore.
            signal.signal(sig, signal.SIG_DFL if previous is None else previous)
        self._previous.clear()
