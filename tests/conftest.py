"""Shared fixtures: the real range scans of tests/data/stanford (see its README)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from registration import MeshModel, load_points
from registration.io.mesh import read_mesh

STANFORD = Path(__file__).parent / "data" / "stanford"


@dataclass(frozen=True)
class RealScan:
    """One real range view: its points (N, 3) in the scanner's frame [m] and the
    ground-truth pose T_model_scan (4, 4) from the scanning repository's alignment."""

    object: str
    name: str
    points: np.ndarray
    T_model_scan: np.ndarray


@dataclass(frozen=True)
class RealObject:
    """A reconstructed model (vertices, faces) [m] and its real views."""

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    scans: tuple[RealScan, ...]

    def model(self) -> MeshModel:
        return MeshModel(self.vertices, self.faces)


def load_real(name: str) -> RealObject:
    folder = STANFORD / name
    poses = json.loads((folder / "poses.json").read_text())["scans"]
    vertices, faces = read_mesh(folder / "model.ply", points_only=False)
    assert faces is not None
    scans = tuple(
        RealScan(name, file, load_points(folder / file), np.array(entry["T_model_scan"]))
        for file, entry in poses.items()
    )
    return RealObject(name, vertices, faces, scans)


@pytest.fixture(scope="session")
def real_objects() -> tuple[RealObject, ...]:
    """The dragon and the Happy Buddha: 9 real views with their true poses."""
    return (load_real("dragon"), load_real("happy"))
