"""Paths of the generated model files."""

from __future__ import annotations

from pathlib import Path

from models.robot.scene_mjcf import ROBOT_FILE

MODEL_DIR = Path(__file__).resolve().parent
#: The nominal robot-only MJCF (Pinocchio parses it; the scene includes it).
ROBOT_PATH = MODEL_DIR / ROBOT_FILE
#: The nominal cell scene.
SCENE_PATH = MODEL_DIR / "scene.xml"
