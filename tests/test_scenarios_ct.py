"""The skull job with its virtual model made from a simulated CT of the phantom
(`model.source: ct`): the model carries a CT's error, and the job meets its goals with it.
The job on a CT volume and a plan as a user gives them (examples/make_ct.py) is run by
docs/tutorials/ct.md's commands (tests/test_docs_commands.py), held to its goals there."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from models.registry import builtin_model
from registration import MeshModel
from scenarios.cli.app import main
from scenarios.configuration.config_files import load_config
from scenarios.jobs.job_plan import object_models

#: Each test meshes simulated CT volumes of the phantom; one runs the job on the mesh.
pytestmark = pytest.mark.slow

SHORT_CT = """seed: 3
model: {source: ct}
localization:
  scan: {speed_m_s: 0.25, period_s: 0.02}
"""


def test_ct_model_error_is_the_scanners(tmp_path: Path) -> None:
    """The virtual model is the phantom's CT: 0.05-0.3 mm from the real phantom on average
    and within 1 mm everywhere; the real object is the phantom itself (no seeded
    deformation), and a coarser CT (1 x 1 x 2 mm) errs more."""
    path = tmp_path / "ct.yaml"
    path.write_text(SHORT_CT)
    config = load_config(path)
    virtual, real = object_models(config)
    truth = MeshModel(np.asarray(real.mesh.vertices), np.asarray(real.mesh.faces))
    d = truth.closest(np.asarray(virtual.mesh.vertices)).distances
    assert 0.05e-3 < d.mean() < 0.3e-3 and d.max() < 1e-3
    assert "CT 0.5 x 0.5 x 1 mm" in virtual.source
    design = builtin_model("skull", seed=3)  # the real object is the design, undeformed
    np.testing.assert_array_equal(real.mesh.vertices, design.mesh.vertices)
    path.write_text(SHORT_CT.replace("{source: ct}", "{source: ct, ct: {voxel_mm: 1x1x2}}"))
    coarse, _ = object_models(load_config(path))
    d_coarse = truth.closest(np.asarray(coarse.mesh.vertices)).distances
    assert d_coarse.mean() > 1.5 * d.mean()


@pytest.mark.filterwarnings("ignore::DeprecationWarning")
def test_skull_job_with_a_ct_model_meets_its_goals(tmp_path: Path) -> None:
    config = tmp_path / "ct.yaml"
    config.write_text(SHORT_CT)
    out = tmp_path / "out"
    assert main(["run", str(config), "--out", str(out), "--quiet", "--no-rrd"]) == 0
    results = json.loads((out / "latest" / "results.json").read_text())
    assert results["status"] == "complete"
    errors = np.array([t["error_m"] for t in results["targets"]])
    assert len(errors) == 4
    assert np.sqrt(np.mean(errors**2)) <= 0.5e-3 and errors.max() <= 1.0e-3
