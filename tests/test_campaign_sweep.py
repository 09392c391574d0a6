"""Campaign sweeps: parsing, crossing, dotted keys, case presets, refusals, trial ids and
seeds, and a trial's row as it is stored."""

from __future__ import annotations

from dataclasses import dataclass
from typing import get_args

import pytest

from scenarios.campaign import (
    CampaignError,
    campaign_trials,
    parse_vary,
    plan_campaign,
    resolve_config,
    run_trial,
    set_dotted,
    sweep_points,
)
from scenarios.campaign import trials as trials_module
from scenarios.campaign.register_job import CASES, register_base
from scenarios.configuration.register_trial_sections import RegisterCase


def test_parse_vary_reads_yaml_scalars() -> None:
    sweep = parse_vary(
        [
            "cell.noise.laser_sigma_m=0.05e-3,1e-4",
            "register_trial.case=default,outliers",
            "register_trial.scan.coverage=none,0.1",
        ]
    )
    assert sweep == (
        ("cell.noise.laser_sigma_m", (0.05e-3, 1e-4)),
        ("register_trial.case", ("default", "outliers")),
        ("register_trial.scan.coverage", (None, 0.1)),
    )


@pytest.mark.parametrize(
    "bad", ["cell.noise.laser_sigma_m", "=1,2", "cell.noise.laser_sigma_m=", "a=1,,2", "a=[1, 2]"]
)
def test_parse_vary_refuses_bad_options(bad: str) -> None:
    with pytest.raises(CampaignError) as info:
        parse_vary([bad])
    assert isinstance(info.value, ValueError)


def test_parse_vary_refuses_a_key_twice() -> None:
    with pytest.raises(CampaignError, match="twice"):
        parse_vary(["a=1", "a=2"])


def test_sweep_points_cross_every_value_last_key_fastest() -> None:
    points = sweep_points((("a", (1, 2)), ("b", ("x", "y", "z"))))
    expected = [
        {"a": 1, "b": "x"}, {"a": 1, "b": "y"}, {"a": 1, "b": "z"},
        {"a": 2, "b": "x"}, {"a": 2, "b": "y"}, {"a": 2, "b": "z"},
    ]  # fmt: skip
    assert points == expected
    assert sweep_points(()) == [{}]


def test_set_dotted_copies_and_names_valid_keys() -> None:
    config = {"noise": {"laser_sigma_m": 1e-4}, "seed": 0}
    out = set_dotted(config, "noise.laser_sigma_m", 3e-4)
    assert out == {"noise": {"laser_sigma_m": 3e-4}, "seed": 0}
    assert config["noise"]["laser_sigma_m"] == 1e-4  # the input is left alone
    with pytest.raises(
        CampaignError, match=r"unknown key 'noise\.laser_sigm': the keys of noise are laser_sigma_m"
    ):
        set_dotted(config, "noise.laser_sigm", 1.0)
    with pytest.raises(CampaignError, match=r"unknown key 'seed\.sub'"):
        set_dotted(config, "seed.sub", 1.0)


def test_case_presets_then_swept_keys() -> None:
    points = "register_trial.scan.points"
    coverage = "register_trial.scan.coverage"
    spec = plan_campaign(
        "skull", trials=2, vary=["register_trial.case=small_scan,outliers", f"{points}=500"]
    )
    small = resolve_config(spec, {"register_trial.case": "small_scan", points: 500})
    assert small["register_trial"]["case"] == "small_scan"
    assert small["register_trial"]["scan"]["coverage"] == CASES["small_scan"][coverage]
    assert small["register_trial"]["scan"]["tilts_deg"] == [0.0]
    assert small["register_trial"]["scan"]["points"] == 500
    # A swept key goes after the case preset.
    spec = plan_campaign(
        "skull", trials=1, vary=["register_trial.case=small_scan", f"{coverage}=0.2"]
    )
    resolved = resolve_config(spec, {"register_trial.case": "small_scan", coverage: 0.2})
    assert resolved["register_trial"]["scan"]["coverage"] == 0.2
    # Everything else is the default job on the skull.
    base = register_base("skull")
    outliers = resolve_config(spec, {"register_trial.case": "outliers"})
    assert outliers["register_trial"]["scan"]["outliers"] == 0.4
    assert outliers["cell"] == base["cell"]
    assert outliers["register_trial"]["arm"] == base["register_trial"]["arm"]
    symmetric = resolve_config(spec, {"register_trial.case": "symmetric"})
    assert symmetric["cell"]["object"]["model"] == "ellipsoid"
    wrong = resolve_config(spec, {"register_trial.case": "wrong_object"})
    assert wrong["register_trial"]["scanned_model"] == "bracket"


def test_the_cases_are_the_schemas() -> None:
    """Every case the job schema takes has its preset, and no other."""
    assert set(CASES) == set(get_args(RegisterCase))


@pytest.mark.parametrize(
    ("vary", "message"),
    [
        (["cell.noise.laser_sigm=1e-4"], "the keys of cell.noise are"),
        (["laser.sigma=1e-4"], r"unknown key 'laser\.sigma'"),  # the old schema's keys
        (["cell.noise.laser_sigma_m=-1"], "cell.noise.laser_sigma_m"),
        (["register_trial.scan.outliers=1.5"], "register_trial.scan.outliers"),
        (["register_trial.scan.pointz=10"], "the keys of register_trial.scan are"),
        (["register_trial.case=round"], "unknown case 'round'; valid: default, symmetric"),
        (["cell.object.model=teapot"], "cell.object.model 'teapot'.*skull, ellipsoid"),
        (["register_trial.scanned_model=teapot"], "register_trial.scanned_model"),
        (["localization.registration.mode=refine"], "needs a prior pose"),
        (["model.source=ct"], "model.source 'ct'"),
        (["faults=table_stall"], "unknown scan fault 'table_stall'.*laser_dropout_burst"),
        (["faults.laser_dropout_burst=4"], r"a burst of 4 s loses 1\.2 of a pass"),
        (["faults.laser_spurious=0.5"], r"range error must be in \(0, 0\.1\] m, got 0\.5"),
        (["calibration.enabled=false"], "register stage does not read this key"),
        (["localization.registration.voxel_m=0.002"], "register stage does not read this key"),
    ],
)
def test_a_bad_sweep_fails_before_any_trial(vary: list[str], message: str) -> None:
    with pytest.raises(CampaignError, match=message):
        plan_campaign("skull", trials=3, vary=vary)


def test_bad_campaign_options_are_refused() -> None:
    with pytest.raises(CampaignError, match="unknown stage"):
        plan_campaign("skull", stage="scan")
    with pytest.raises(CampaignError, match="trials must be"):
        plan_campaign("skull", trials=0)
    with pytest.raises(CampaignError, match="register stage"):
        plan_campaign("teapot")


def test_trials_have_unique_ids_and_common_seeds_across_points() -> None:
    spec = plan_campaign(
        "skull", trials=4, vary=["cell.noise.laser_sigma_m=1e-4,2e-4,3e-4"], seed=10
    )
    trials = campaign_trials(spec)
    assert len(trials) == 12
    assert len({t.trial_id for t in trials}) == 12
    for point in range(3):
        mine = [t for t in trials if t.point == point]
        assert [t.seed for t in mine] == [10, 11, 12, 13]
        sigmas = {t.config["cell"]["noise"]["laser_sigma_m"] for t in mine}
        assert sigmas == {[1e-4, 2e-4, 3e-4][point]}


@dataclass(frozen=True)
class _Row:
    value: float
    doubled: float


def test_a_trial_row_is_stored_as_its_columns(monkeypatch) -> None:
    """A trial function returns a typed row; the campaign stores its columns (the results'
    converter's mapping of it), after the trial's ids."""
    result = _Row(1.5, 3.0)
    monkeypatch.setattr(trials_module, "stage_function", lambda stage: lambda config, seed: result)
    trial = campaign_trials(plan_campaign("skull", trials=1))[0]
    row = run_trial(trial)
    assert row["status"] == "ok", row["error"]
    assert list(row)[-2:] == ["value", "doubled"] and (row["value"], row["doubled"]) == (1.5, 3.0)
