"""Campaign sweeps: parsing, crossing, dotted keys, case presets, trial ids and seeds."""

from __future__ import annotations

import pytest

from scenarios.campaign import (
    CampaignError,
    campaign_trials,
    parse_vary,
    plan_campaign,
    resolve_config,
    set_dotted,
    sweep_points,
)
from scenarios.campaign.register_config import CASES, default_register_config


def test_parse_vary_reads_yaml_scalars() -> None:
    sweep = parse_vary(
        ["laser.sigma=0.05e-3,1e-4", "case=default,outliers", "scan.coverage=none,0.1"]
    )
    assert sweep == (
        ("laser.sigma", (0.05e-3, 1e-4)),
        ("case", ("default", "outliers")),
        ("scan.coverage", (None, 0.1)),
    )


@pytest.mark.parametrize("bad", ["laser.sigma", "=1,2", "laser.sigma=", "a=1,,2", "a=[1, 2]"])
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
    config = {"laser": {"sigma": 1e-4}, "case": "default"}
    out = set_dotted(config, "laser.sigma", 3e-4)
    assert out == {"laser": {"sigma": 3e-4}, "case": "default"}
    assert config["laser"]["sigma"] == 1e-4  # the input is left alone
    with pytest.raises(
        CampaignError, match=r"unknown key 'laser\.sigm': the keys of laser are sigma"
    ):
        set_dotted(config, "laser.sigm", 1.0)
    with pytest.raises(CampaignError, match=r"unknown key 'case\.sub'"):
        set_dotted(config, "case.sub", 1.0)


def test_case_presets_then_swept_keys() -> None:
    spec = plan_campaign("skull", trials=2, vary=["case=small_scan,outliers", "scan.points=500"])
    small = resolve_config(spec, {"case": "small_scan", "scan.points": 500})
    assert small["case"] == "small_scan"
    assert small["scan"]["coverage"] == CASES["small_scan"]["scan.coverage"]
    assert small["scan"]["tilts_deg"] == [0.0]
    assert small["scan"]["points"] == 500
    # A swept key goes after the case preset.
    spec = plan_campaign("skull", trials=1, vary=["case=small_scan", "scan.coverage=0.2"])
    assert (
        resolve_config(spec, {"case": "small_scan", "scan.coverage": 0.2})["scan"]["coverage"]
        == 0.2
    )
    # Everything else is the default configuration.
    base = default_register_config()
    outliers = resolve_config(spec, {"case": "outliers"})
    assert outliers["scan"]["outliers"] == 0.4
    assert outliers["laser"] == base["laser"] and outliers["arm"] == base["arm"]


@pytest.mark.parametrize(
    ("vary", "message"),
    [
        (["laser.sigm=1e-4"], "the keys of laser are"),
        (["laser.sigma=-1"], "laser.sigma"),
        (["case=round"], "unknown case 'round'"),
        (["model=teapot"], "model"),
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
    spec = plan_campaign("skull", trials=4, vary=["laser.sigma=1e-4,2e-4,3e-4"], seed=10)
    trials = campaign_trials(spec)
    assert len(trials) == 12
    assert len({t.trial_id for t in trials}) == 12
    for point in range(3):
        mine = [t for t in trials if t.point == point]
        assert [t.seed for t in mine] == [10, 11, 12, 13]
        assert {t.config["laser"]["sigma"] for t in mine} == {[1e-4, 2e-4, 3e-4][point]}
