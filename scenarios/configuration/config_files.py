"""Reading job configurations: a shipped one by name (`shipped/<name>.yaml`, cells in
`shipped/cells/`), a user's file with the files it names found beside it, and `--set KEY=VALUE`
overrides by dotted key; what is wrong is named, with the valid keys."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import yaml
from pydantic import (
    ValidationError,
)

from cell.sim.faults import FAULT_KINDS
from scenarios.configuration.config_error import ConfigError
from scenarios.configuration.job_config import (
    KINDS,
    Config,
)
from scenarios.results.edge import JsonObject

CONFIG_DIR = Path(__file__).parent / "shipped"
CELL_DIR = CONFIG_DIR / "cells"


def shipped_names() -> tuple[str, ...]:
    """Names of the configurations shipped with the package."""
    return tuple(sorted(p.stem for p in CONFIG_DIR.glob("*.yaml")))


def describe_validation_error(error: ValidationError) -> str:
    """A pydantic validation error in one line: unknown keys and bad values, each named."""
    parts = []
    for item in error.errors():
        where = ".".join(str(x) for x in item["loc"]) or "(top)"
        if item["type"] == "extra_forbidden":
            parts.append(f"unknown key {where!r}")
        else:
            parts.append(f"{where}: {item['msg']} (got {item.get('input')!r})")
    return "; ".join(parts)


def read_yaml_mapping(path: Path, error: type[Exception] = ConfigError) -> JsonObject:
    """The mapping in a YAML file; a missing file, bad YAML or a non-mapping raise `error`."""
    if not path.is_file():
        raise error(f"{path}: no such configuration file")
    try:
        data = yaml.safe_load(path.read_text()) or {}
    except yaml.YAMLError as exc:
        raise error(f"{path}: not valid YAML: {exc}") from None
    if not isinstance(data, dict):
        raise error(f"{path}: a configuration must be a mapping of keys")
    return data


def parse_config(data: JsonObject, source: str = "config") -> Config:
    """Validate a configuration mapping; its `kind` key ("cell" by default) picks the
    schema."""
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: a configuration must be a mapping, got {type(data).__name__}")
    kind = data.get("kind", "cell")
    if kind not in KINDS:
        raise ConfigError(f"{source}: 'kind' must be one of {sorted(KINDS)}, got {kind!r}")
    try:
        return KINDS[kind].model_validate(data)
    except ValidationError as exc:
        raise ConfigError(f"{source}: {describe_validation_error(exc)}") from None


def set_dotted(data: JsonObject, key: str, value: Any) -> JsonObject:
    """A deep copy of the mapping `data` with the dotted `key` (e.g. "cell.noise.laser_sigma_m")
    set to `value`. Every part of the path but the last must already exist: a typo is refused,
    naming the keys that do."""
    out = copy.deepcopy(data)
    node = out
    parts = key.split(".")
    for depth, part in enumerate(parts):
        if not isinstance(node, dict) or part not in node:
            where = ".".join(parts[:depth]) or "(top)"
            valid = ", ".join(sorted(node)) if isinstance(node, dict) else "none (not a section)"
            raise ConfigError(f"unknown key {key!r}: the keys of {where} are {valid}")
        if depth == len(parts) - 1:
            node[part] = value
        else:
            node = node[part]
    return out


def with_overrides(config: Config, overrides: JsonObject, source: str = "--set") -> Config:
    """The configuration with each dotted key of `overrides` set to its value, validated as
    the YAML is (a bad key or value raises ConfigError naming it)."""
    data = config.model_dump(mode="json")
    for key, value in overrides.items():
        data = set_dotted(data, key, value)
    return parse_config(data, source)


def parse_assignment(text: str) -> tuple[str, Any]:
    """KEY=VALUE of `--set`: the value read as YAML (numbers, true/false, null, lists)."""
    key, sep, raw = text.partition("=")
    if not sep or not key.strip():
        raise ConfigError(f"--set takes KEY=VALUE with a dotted KEY, got {text!r}")
    try:
        value = yaml.safe_load(raw) if raw.strip() else ""
    except yaml.YAMLError as exc:
        raise ConfigError(f"--set {text!r}: the value is not valid YAML ({exc})") from None
    return key.strip(), value


def fault_assignment(text: str) -> tuple[str, Any]:
    """NAME[=AMOUNT[:OPTION]] of `--fault`: the dotted key `faults.NAME` and its value (the
    amount, "AMOUNT:OPTION", or true for the kind's defaults); an unknown name lists the
    faults."""
    name, sep, raw = text.partition("=")
    name = name.strip()
    if name not in FAULT_KINDS:
        raise ConfigError(
            f"--fault {text!r}: unknown fault {name!r}; the faults are: " + ", ".join(FAULT_KINDS)
        )
    if not sep:
        return f"faults.{name}", True
    raw_amount, colon, option = raw.partition(":")
    kind = FAULT_KINDS[name]
    try:
        amount = float(raw_amount)
    except ValueError:
        raise ConfigError(
            f"--fault {text!r}: the amount must be a number ({kind.amount} [{kind.unit}], "
            f"default {kind.default:g})"
        ) from None
    if not colon:
        return f"faults.{name}", amount
    if option not in kind.options:
        valid = ", ".join(kind.options) or "none"
        raise ConfigError(f"--fault {text!r}: option {option!r} is not one of: {valid}")
    return f"faults.{name}", f"{amount!r}:{option}"


def shipped_cells() -> tuple[str, ...]:
    """Names of the cells shipped with the package (`--cell NAME`)."""
    return tuple(sorted(p.stem for p in CELL_DIR.glob("*.yaml")))


def _flatten(data: JsonObject, prefix: str = "") -> JsonObject:
    out: JsonObject = {}
    for key, value in data.items():
        dotted = f"{prefix}{key}"
        if isinstance(value, dict):
            out |= _flatten(value, dotted + ".")
        else:
            out[dotted] = value
    return out


def _shipped_or_file(
    name_or_path: str | Path, kind: str, shipped: tuple[str, ...], folder: Path
) -> Path:
    """The YAML of a shipped `kind` by name (in `folder`) or a user's .yaml file by path."""
    text = str(name_or_path)
    if text in shipped:
        return folder / f"{text}.yaml"
    path = Path(text)
    if path.suffix not in (".yaml", ".yml"):
        raise ConfigError(
            f"unknown {kind} {text!r}; shipped: {', '.join(shipped)}, or give a .yaml file"
        )
    return path


def cell_overrides(name_or_path: str | Path) -> JsonObject:
    """A cell (`--cell`): a shipped one by name or a YAML file by path, holding the keys of
    a job configuration that make the cell (the `cell` section's robot and rack, and what
    follows from the layout, e.g. `calibration.table_positions_m`); returned as dotted
    overrides of the job's configuration, validated with it. A file it names (the robot's,
    say) is found beside it (FILE_KEYS)."""
    path = _shipped_or_file(name_or_path, "cell", shipped_cells(), CELL_DIR)
    return _flatten(_files_beside(read_yaml_mapping(path), path.parent))


#: The keys of a configuration that may name a file (or a CT series' folder).
FILE_KEYS = (
    "cell.robot.model",
    "cell.object.model",
    "cell.object.targets_file",
    "operations.program",
)


def _files_beside(data: JsonObject, folder: Path) -> JsonObject:
    """`data` with each relative file of FILE_KEYS that exists beside the configuration file
    (in `folder`) made absolute: a job's files are found beside its YAML, wherever it runs."""
    out = data
    flat = _flatten(data)
    for key in FILE_KEYS:
        value = flat.get(key)
        if isinstance(value, str) and not Path(value).is_absolute():
            beside = folder / value
            if beside.exists():
                out = set_dotted(out, key, str(beside.resolve()))
    return out


def load_config(
    name_or_path: str | Path,
    overrides: JsonObject | None = None,
    cell: str | Path | None = None,
) -> Config:
    """A shipped configuration by name or a YAML file by path, with `overrides` (dotted keys,
    e.g. {"seed": 3, "cell.object.model": "part.stl"}) applied and validated, after the
    `cell` (see `cell_overrides`) if one is given. A configuration without a `name` is named
    after its file."""
    path = _shipped_or_file(name_or_path, "job", shipped_names(), CONFIG_DIR)
    data = _files_beside(read_yaml_mapping(path), path.parent)
    data.setdefault("name", path.stem)
    config = parse_config(data, str(path))
    if cell is not None:
        config = with_overrides(config, cell_overrides(cell), f"cell {cell}")
    return with_overrides(config, overrides, str(path)) if overrides else config


def config_yaml(config: Config) -> str:
    """The resolved configuration as YAML (every key, defaults included)."""
    return yaml.safe_dump(config.model_dump(mode="json"), sort_keys=False)
