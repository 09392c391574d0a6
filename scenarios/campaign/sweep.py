"""Sweeps: `--vary KEY=V1,V2,...` options parsed, crossed, and applied to nested config dicts.

Keys are dotted paths into the job's configuration (`cell.noise.laser_sigma_m`,
`register_trial.scan.coverage`); values are numbers when they read as Python numbers (`500`,
`1e-4`), None for `none`/`null`, and YAML scalars otherwise (`true`, `skull`).
"""

from __future__ import annotations

import itertools
from typing import Any

import yaml

from scenarios.campaign.campaign_errors import CampaignError
from scenarios.configuration.config_error import ConfigError
from scenarios.configuration.config_files import set_dotted as config_set_dotted
from scenarios.results.edge import JsonObject

Sweep = tuple[tuple[str, tuple[Any, ...]], ...]
"""Ordered (key, values) pairs; the sweep points are their cross product."""


def _scalar(text: str) -> Any:
    if text.lower() in ("none", "null", "~"):
        return None
    for number in (int, float):
        try:
            return number(text)
        except ValueError:
            continue
    return _yaml_scalar(text)


def _yaml_scalar(text: str) -> Any:
    """YAML's reading of a value that is not a number (true, a name)."""
    try:
        value = yaml.safe_load(text)
    except yaml.YAMLError:
        raise CampaignError(f"sweep value {text!r} is not a scalar") from None
    if isinstance(value, dict | list):
        raise CampaignError(f"sweep value {text!r} must be a scalar, not a {type(value).__name__}")
    return value


def parse_vary(options: list[str] | tuple[str, ...]) -> Sweep:
    """Parse `KEY=V1,V2,...` strings into a sweep; a key may appear once."""
    sweep: list[tuple[str, tuple[Any, ...]]] = []
    for option in options:
        key, sep, values = option.partition("=")
        key = key.strip()
        parts = [v.strip() for v in values.split(",")]
        if not sep or not key or not values.strip() or any(not p for p in parts):
            raise CampaignError(
                f"--vary {option!r}: expected KEY=V1,V2,... "
                "(e.g. cell.noise.laser_sigma_m=0.05e-3,0.1e-3)"
            )
        if any(key == k for k, _ in sweep):
            raise CampaignError(f"--vary: key {key!r} given twice")
        sweep.append((key, tuple(_scalar(p) for p in parts)))
    return tuple(sweep)


def sweep_points(sweep: Sweep) -> list[JsonObject]:
    """The cross product of the sweep: one {key: value} dict per point (one empty point when
    nothing varies), the last key varying fastest."""
    keys = [k for k, _ in sweep]
    return [
        dict(zip(keys, combo, strict=True)) for combo in itertools.product(*(v for _, v in sweep))
    ]


def set_dotted(config: JsonObject, key: str, value: Any) -> JsonObject:
    """A deep copy of `config` with the dotted `key` set to `value` (see
    scenarios.configuration.config_files.set_dotted); a typo raises CampaignError naming the
    keys that exist."""
    try:
        return config_set_dotted(config, key, value)
    except ConfigError as exc:
        raise CampaignError(str(exc)) from None
