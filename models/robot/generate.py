"""Write the nominal model files beside this module: `python -m models.robot.generate`.

The files on disk are the generators' output for the nominal cell; a test checks that they
have not drifted from the code.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from models.robot.arm import arm_xml
from models.robot.paths import ROBOT_PATH, SCENE_PATH
from models.robot.scene import scene_xml


def _write_atomic(path: Path, text: str) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def generate() -> tuple[Path, Path]:
    """Write the nominal robot-only MJCF and the scene; return their paths."""
    _write_atomic(ROBOT_PATH, arm_xml())
    _write_atomic(SCENE_PATH, scene_xml())
    return ROBOT_PATH, SCENE_PATH


if __name__ == "__main__":
    for p in generate():
        print(p)
