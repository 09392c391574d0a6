"""Write the nominal model files beside this module: `python -m models.robot.generate`.

The files on disk are the generators' output for the nominal cell; a test checks that they
have not drifted from the code.
"""

from __future__ import annotations

from pathlib import Path

from models.atomic import write_text
from models.robot.arm import arm_xml
from models.robot.paths import ROBOT_PATH, SCENE_PATH
from models.robot.scene_mjcf import scene_xml


def generate() -> tuple[Path, Path]:
    """Write the nominal robot-only MJCF and the scene; return their paths."""
    write_text(ROBOT_PATH, arm_xml())
    write_text(SCENE_PATH, scene_xml())
    return ROBOT_PATH, SCENE_PATH


if __name__ == "__main__":
    for p in generate():
        print(p)
