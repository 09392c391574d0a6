"""The import contracts of pyproject.toml hold (registration stands alone; the offline stages
never import the simulation, the cell's truth or the evaluator), and the checker does catch
a broken one."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _lint(config: Path) -> subprocess.CompletedProcess[str]:
    lint = shutil.which("lint-imports") or str(Path(sys.executable).parent / "lint-imports")
    return subprocess.run(
        [lint, "--config", str(config), "--no-cache"],
        cwd=ROOT,
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
