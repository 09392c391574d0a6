"""A run folder: runs/<name>-<timestamp>/, files written completely or not at all.

Every file goes to a temporary name in the folder and is renamed into place, so a reader
never sees half a file. results.json says "status": "incomplete" with the reason until the
run finishes; `runs/latest` points at the newest finished or failed run.

A temporary name starts with a dot: `.<name>.<random>.tmp` (models.atomic) or
`.<name>.partial` (the recording); a run that stops early removes any left.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from models.atomic import write_text


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value


def write_json(path: Path, data: Any) -> Path:
    """Write data as indented JSON, atomically; numpy values become plain numbers."""
    text = json.dumps(_jsonable(data), indent=2) + "\n"
    return write_text(path, text)


class RunFolder:
    """The folder of one run, created under `root` as <name>-<YYYYmmdd-HHMMSS>[-k]."""

    def __init__(self, root: str | Path, name: str) -> None:
        self.root = Path(root)
        stamp = time.strftime("%Y%m%d-%H%M%S")
        path = self.root / f"{name}-{stamp}"
        k = 1
        while path.exists():
            k += 1
            path = self.root / f"{name}-{stamp}-{k}"
        path.mkdir(parents=True)
        self.path = path

    def file(self, name: str) -> Path:
        """Path of a file in the run folder."""
        return self.path / name

    def write_text(self, name: str, text: str) -> Path:
        return write_text(self.file(name), text)

    def write_json(self, name: str, data: Any) -> Path:
        return write_json(self.file(name), data)

    def remove_partial(self) -> list[Path]:
        """Delete the temporary files of writes that did not finish (see the module's
        docstring) and return them. Each writer removes its own when it fails; a signal
        can still land between a temporary file's creation and the writer's cleanup, and a
        run that stops early calls this last so that no such file outlives it."""
        left = [
            p
            for p in self.path.iterdir()
            if p.name.startswith(".") and p.name.endswith((".tmp", ".partial")) and p.is_file()
        ]
        for p in left:
            p.unlink(missing_ok=True)
        return left

    def link_latest(self) -> None:
        """Point root/latest at this run (a symbolic link, replaced atomically)."""
        link = self.root / "latest"
        tmp = self.root / f".latest.{os.getpid()}"
        tmp.unlink(missing_ok=True)
        tmp.symlink_to(self.path.name)
        os.replace(tmp, link)
