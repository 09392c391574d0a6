"""twincell as a pytest plugin, tested with pytest's own pytester: a generated user project
whose tests use the plugin's fixtures and assertions, run by pytest as the user would."""

from __future__ import annotations

import re
from pathlib import Path

import abb_robot_client.rws  # noqa: F401
import pytest
import yaml

# pytester runs pytest in this process and forgets the modules each run imported; what the
# runs use (pinocchio's and MuJoCo's bindings, the RWS client's classes) is imported before
# any of them, so that it stays
import scenarios.jobs.runner
import scenarios.jobs.serve  # noqa: F401

pytest_plugins = ["pytester"]

#: A quicker scan than the shipped job's: 0.25 m/s, a line every 20 ms.
FAST = '{"localization.scan.speed_m_s": 0.25, "localization.scan.period_s": 0.02}'

USER_TESTS = f"""
import pytest
from abb_robot_client.rws import RWS
from scenarios.testing import assert_goals, assert_targets_within

FAST = {FAST}


@pytest.mark.twincell_seeds(2, start=5)
def test_over_seeds(run_job, twincell_seed):
    run = run_job("skull", seed=twincell_seed, overrides=FAST)
    assert run.seed == twincell_seed
    assert_goals(run)
    if twincell_seed == 6:  # and a tolerance no arm meets
        assert_targets_within(run, 0.05e-3)


def test_a_bad_configuration(run_job):
    run_job("skull", overrides={{"localization.scan.speed_m_s": -1}})


def test_the_served_twin(served_twin):
    twin = served_twin("skull", speed=10.0)
    assert RWS(twin.url).get_controller_state() == "motoron"
"""


def test_seeds_parametrise_the_tests(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(
        test_seeds="""
import pytest

@pytest.mark.twincell_seeds(3, start=10)
def test_marked(twincell_seed):
    assert 10 <= twincell_seed < 13

def test_plain(twincell_seed):
    assert twincell_seed == 0

def test_without(tmp_path):
    pass
"""
    )
    result = pytester.runpytest("-p", "no:xdist", "--collect-only", "-q")
    ids = [line for line in result.outlines if "::" in line]
    assert ids == [
        "test_seeds.py::test_marked[seed10]",
        "test_seeds.py::test_marked[seed11]",
        "test_seeds.py::test_marked[seed12]",
        "test_seeds.py::test_plain[seed0]",
        "test_seeds.py::test_without",
    ]
    result = pytester.runpytest("-p", "no:xdist", "--collect-only", "-q", "--twincell-seeds", "2")
    assert sum("test_marked[" in line for line in result.outlines) == 2
    assert sum("test_plain[" in line for line in result.outlines) == 2
    result = pytester.runpytest("-p", "no:xdist", "-q", "--twincell-seeds", "2")
    result.assert_outcomes(passed=4, failed=1)  # test_plain's seed 1 fails


def test_passed_tests_leave_no_folders_unless_kept(
    pytester: pytest.Pytester, tmp_path: Path
) -> None:
    pytester.makepyfile(
        test_twin="""
from abb_robot_client.rws import RWS

def test_the_served_twin(served_twin):
    twin = served_twin("skull")
    assert RWS(twin.url).get_operation_mode() == "AUTO"
"""
    )
    for keep, left in ((False, 0), (True, 1)):
        out = tmp_path / f"keep{keep}"
        args = ["-p", "no:xdist", "-p", "no:cacheprovider", "--twincell-out", str(out)]
        result = pytester.runpytest(*args, *(["--twincell-keep"] if keep else []))
        result.assert_outcomes(passed=1)
        assert len(list(out.glob("*/serve-skull-*"))) == left


def test_the_served_twin_serves_the_users_cell_and_settings(
    pytester: pytest.Pytester, tmp_path: Path
) -> None:
    # The user's cell file and a dotted setting reach the served cell, as they reach run_job's;
    # ground truth: the cell file's own home, read here from its YAML.
    cell_file = Path(__file__).resolve().parent.parent / "examples" / "my_cell" / "cell.yaml"
    home_deg = yaml.safe_load(cell_file.read_text())["cell"]["robot"]["home_deg"]
    pytester.makepyfile(
        test_twin=f"""
def test_the_users_cell(served_twin):
    twin = served_twin("skull", cell={str(cell_file)!r},
                       overrides={{"cell.noise.laser_sigma_m": 2e-4}})
    assert list(twin.config.cell.robot.home_deg) == {home_deg!r}
    assert twin.config.cell.noise.laser_sigma_m == 2e-4

def test_the_jobs_own_cell(served_twin):
    assert served_twin("skull").config.cell.robot.home_deg is None

def test_a_cell_that_runs_no_rapid(served_twin):
    served_twin("skull", cell="ur5")
"""
    )
    args = ["-p", "no:xdist", "-p", "no:cacheprovider", "--twincell-out", str(tmp_path / "out")]
    result = pytester.runpytest(*args)
    result.assert_outcomes(passed=2, failed=1)
    text = "\n".join(result.outlines)
    assert "twincell: error: skull: the job's arm, the ur5, does not run RAPID" in text


@pytest.mark.slow
def test_a_user_project(pytester: pytest.Pytester, tmp_path: Path) -> None:
    pytester.makepyfile(test_my_cell=USER_TESTS)
    out = tmp_path / "runs"
    result = pytester.runpytest(
        "-p", "no:xdist", "-p", "no:cacheprovider", "--twincell-no-rrd", "--twincell-out", str(out)
    )  # fmt: skip
    result.assert_outcomes(passed=2, failed=2)  # seed 5 and the twin; seed 6 and the refusal
    text = "\n".join(result.outlines)
    # the failing run: its targets by name, their errors, the limit, the seed, the folder
    failure = text[text.index("_ test_over_seeds[seed6] _") :]
    assert "job skull, seed 6" in failure
    assert re.search(r"kocher_right: \d+\.\d{3} mm > 0\.050 mm", failure)
    folder = re.search(r"run folder (\S+)", failure)
    assert folder is not None and (Path(folder.group(1)) / "results.json").is_file()
    # the session's summary lists it
    summary = text[text.index("twincell: run folders of the failed tests") :]
    assert f"test_my_cell.py::test_over_seeds[seed6]: {folder.group(1)}" in summary
    # a configuration the project refuses: its one line, no traceback from the pipeline
    bad = text[text.index("_ test_a_bad_configuration _") :]
    assert "twincell: error:" in bad and "speed_m_s" in bad and "Traceback" not in bad
    # the seed-parametrised test ran once per seed, each in a folder of its own; the passed
    # seed's run is removed, the failed one's kept
    seeds = {"test_my_cell.py_test_over_seeds_seed5_", "test_my_cell.py_test_over_seeds_seed6_"}
    assert seeds <= {p.name for p in out.iterdir()}
    runs = {p.resolve().parent for p in out.glob("*/*/results.json")}  # not `latest`
    assert [p.parent.name for p in runs] == ["test_my_cell.py_test_over_seeds_seed6_"]
    # and no `latest` link is left pointing at the removed run
    assert not [p for p in out.rglob("*") if p.is_symlink() and not p.exists()]
    assert (out / "test_my_cell.py_test_over_seeds_seed6_" / "latest").exists()
