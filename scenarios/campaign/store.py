"""The result store of a campaign folder: one small JSON per finished trial, then one CSV.

Each trial's row is written to `trials/<trial_id>.json` through a temporary file, fsync and
an atomic rename, by the one process that collects the results: a row is there completely or
not at all, and a trial id names one file, so a restarted campaign skips the finished trials
and no result is lost or counted twice. The CSV (one row per trial, flat columns) is rebuilt
from the JSON files, also atomically. A crashed trial (status "crash") also has a folder,
`trials/<trial_id>/`, holding its full traceback (`traceback.txt`), written the same way
before its row; the row names the file in its `traceback` column.
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from models.atomic import write_text
from scenarios.campaign.trials import TRACEBACK_TEXT
from scenarios.results.edge import JsonObject


def _plain(value: Any) -> Any:
    """JSON-ready scalars: numpy numbers become Python ones, non-finite floats stay floats."""
    if hasattr(value, "item"):
        return value.item()
    return value


class ResultStore:
    """The finished trials of one campaign folder."""

    def __init__(self, folder: str | Path) -> None:
        self.folder = Path(folder)
        self.trials_dir = self.folder / "trials"

    def path(self, trial_id: str) -> Path:
        return self.trials_dir / f"{trial_id}.json"

    def done(self) -> set[str]:
        """Ids of the trials whose rows are stored."""
        if not self.trials_dir.is_dir():
            return set()
        return {p.stem for p in self.trials_dir.glob("*.json")}

    def traceback_path(self, trial_id: str) -> Path:
        """Where the full traceback of the crashed trial `trial_id` is written."""
        return self.trials_dir / trial_id / "traceback.txt"

    def write(self, row: JsonObject) -> Path:
        """Store one row (must hold "trial_id"). A crashed trial's traceback (the row's
        TRACEBACK_TEXT) goes to traceback_path first, and the row keeps the file's path
        relative to the campaign folder as `traceback`; any other row removes a traceback
        left by an earlier run of its trial (a crashed row deleted to run it again)."""
        trial_id = str(row["trial_id"])
        traceback = self.traceback_path(trial_id)
        if TRACEBACK_TEXT in row:
            row = dict(row)
            write_text(traceback, str(row.pop(TRACEBACK_TEXT)))
            row["traceback"] = traceback.relative_to(self.folder).as_posix()
        elif traceback.exists():
            traceback.unlink()
            with contextlib.suppress(OSError):  # not empty: a killed writer's temporary file
                traceback.parent.rmdir()
        return write_text(
            self.path(trial_id),
            json.dumps({k: _plain(v) for k, v in row.items()}, sort_keys=False),
        )

    def rows(self, ids: Iterable[str] | None = None) -> list[JsonObject]:
        """The stored rows (only `ids` if given), sorted by trial id."""
        wanted = sorted(self.done() if ids is None else set(ids) & self.done())
        return [json.loads(self.path(i).read_text(encoding="utf-8")) for i in wanted]

    def write_csv(self, path: str | Path, rows: list[JsonObject]) -> Path:
        """The rows as a CSV table (columns in first-seen order; missing cells empty)."""
        columns: dict[str, None] = {}
        for row in rows:
            columns.update(dict.fromkeys(row))
        buffer = io.StringIO()
        writer = csv.DictWriter(buffer, fieldnames=list(columns), restval="", lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
        return write_text(Path(path), buffer.getvalue())


def read_csv(path: str | Path) -> list[dict[str, str]]:
    """The rows of a results table, as strings."""
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))
