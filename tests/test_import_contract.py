"""The import contracts of pyproject.toml hold (registration stands alone; the controller's
side of the cell knows nothing of its simulation; the planning and the stages never import
the simulation, the truth, the evaluator, the runner or the job's configuration, not even
through another module), and the checker does catch a broken one."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _lint(config: Path, cwd: Path = ROOT) -> subprocess.CompletedProcess[str]:
    lint = shutil.which("lint-imports") or str(Path(sys.executable).parent / "lint-imports")
    return subprocess.run(
        [lint, "--config", str(config), "--no-cache"],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_the_project_keeps_its_import_contracts() -> None:
    run = _lint(ROOT / "pyproject.toml")
    assert run.returncode == 0, run.stdout + run.stderr
    assert "BROKEN" not in run.stdout and "0 broken" in run.stdout


def test_a_broken_contract_is_caught(tmp_path: Path) -> None:
    # The evaluator's package imports the offline stages (it may: the real cell is set up
    # from the plan); a contract that forbids it must therefore fail.
    config = tmp_path / "contracts.toml"
    config.write_text(
        (ROOT / "pyproject.toml").read_text()
        + "\n[[tool.importlinter.contracts]]\n"
        + 'name = "probe"\ntype = "forbidden"\n'
        + 'source_modules = ["scenarios.realcell"]\nforbidden_modules = ["scenarios.offline"]\n'
        + "allow_indirect_imports = true\n"
    )
    run = _lint(config)
    assert run.returncode != 0
    assert "probe BROKEN" in run.stdout.replace("\n", " ")


PROBES = {
    "the truth and the factory": "from cell.sim.factory import make_cell\n"
    "from cell.sim.truth import CellTruth\n",
    "the evaluator": "from scenarios.realcell.evaluation import Evaluator\n",
    "the runner": "from scenarios.jobs.pipeline import run_cell_job\n",
    "the job's configuration": "from scenarios.configuration.job_config import JobConfig\n",
}


def test_a_planning_module_that_imports_the_truth_breaks_the_contract(tmp_path: Path) -> None:
    # A copy of the project's packages with probe modules in the stages', the planning's, the
    # served controller's and the controller client's packages that import what they must
    # never see: lint-imports
    # then fails, naming each probe's import; the same copy without the probes passes.
    for package in ("cell", "models", "registration", "scenarios"):
        shutil.copytree(
            ROOT / package,
            tmp_path / package,
            ignore=shutil.ignore_patterns("__pycache__", "*.stl", "*.obj", "*.xml", "*.yaml"),
        )
    config = tmp_path / "pyproject.toml"
    shutil.copy(ROOT / "pyproject.toml", config)
    clean = _lint(config, cwd=tmp_path)
    assert clean.returncode == 0, clean.stdout + clean.stderr
    for i, (what, source) in enumerate(PROBES.items()):
        package = ("stages", "offline", "twin", "irc5")[i % 4]
        (tmp_path / "scenarios" / package / f"probe_{i}.py").write_text(
            f'"""A probe that imports {what}."""\n\n' + source
        )
    # the controller's client must not reach MuJoCo either, not even through the cell
    (tmp_path / "scenarios" / "irc5" / "probe_mujoco.py").write_text(
        '"""A probe that reaches MuJoCo through the cell\'s package."""\n\n'
        "from cell import Controller\n"
    )
    run = _lint(config, cwd=tmp_path)
    out = run.stdout.replace("\n", " ")
    assert run.returncode != 0, out
    assert "the planning, RAPID and the stages never see the truth" in out
    assert "the served controller knows what a controller knows" in out
    assert "the controller's client knows what a controller's user knows" in out
    for name in (*(f"probe_{i}" for i in range(len(PROBES))), "probe_mujoco"):
        assert name in out, (name, out)


def test_no_module_hides_an_import_behind_getattr() -> None:
    """A module-level __getattr__ would export names that static analysis (the contracts)
    cannot see: none of the four packages has one."""
    import ast

    found = [
        f"{path.relative_to(ROOT)}:{node.lineno}"
        for package in ("cell", "models", "registration", "scenarios")
        for path in sorted((ROOT / package).rglob("*.py"))
        for node in ast.parse(path.read_text()).body
        if isinstance(node, ast.FunctionDef) and node.name == "__getattr__"
    ]
    assert found == []
