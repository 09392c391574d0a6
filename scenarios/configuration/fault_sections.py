"""The faults a job's real cell is given (cell.sim.faults.FAULT_KINDS), as a configuration
section: by name with their defaults, or each with its amount, stage and option."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import (
    Field,
    model_validator,
)

from cell.sim.faults import FAULT_KINDS, STAGES
from scenarios.offline.settings import (
    Section,
)


class FaultSetting(Section):
    """One fault injected into the real cell (cell.sim.faults.FAULT_KINDS): how much (`amount`,
    SI, None: the kind's default), when (`stage`, None: the kind's default) and its
    `option` (the table readout `honest` or `lying`, the tool of `tool_lock_fail` or
    `payload`). In YAML or `--set`/`--vary`, a bare number is the amount and `true` the
    defaults."""

    amount: float | None = Field(None, ge=0.0)
    stage: Literal[STAGES] | None = None  # type: ignore[valid-type]
    option: str | None = None


def fault_mapping(value: Any, known: Any, unknown: str) -> Any:
    """A faults section as a mapping of name to setting: "a,b" or a list of names (each with
    its defaults) or a mapping; a name not in `known` raises ValueError with `unknown`
    formatted with it."""
    if isinstance(value, str):
        value = [v.strip() for v in value.split(",") if v.strip() and v.strip() != "none"]
    if isinstance(value, list | tuple):
        value = {name: True for name in value}
    if isinstance(value, dict):
        for k in value:
            if k not in known:
                raise ValueError(unknown.format(k))
    return value


def _fault_setting(value: Any) -> Any:
    """A bare number is the amount, "AMOUNT:OPTION" the amount and the option
    (`--vary faults.table_stall=0.002:lying,0.005:lying`), true the defaults, false or null
    no fault."""
    if value is True:
        return {}
    if value is False:
        return None
    if isinstance(value, int | float):
        return {"amount": value}
    if isinstance(value, str) and ":" in value:
        amount, _, option = value.partition(":")
        try:
            return {"amount": float(amount), "option": option.strip()}
        except ValueError:
            return value  # the schema names what is wrong
    return value


class FaultsSection(Section):
    """The faults the real cell will have (none by default). A list or a comma-separated
    string of names gives each its defaults (`--vary faults=table_stall,object_bump`)."""

    tool_lock_fail: FaultSetting | None = None
    laser_dropout_burst: FaultSetting | None = None
    laser_spurious: FaultSetting | None = None
    table_stall: FaultSetting | None = None
    object_bump: FaultSetting | None = None
    encoder_glitch: FaultSetting | None = None
    obstacle: FaultSetting | None = None
    payload: FaultSetting | None = None

    @model_validator(mode="before")
    @classmethod
    def _names(cls, value: Any) -> Any:
        value = fault_mapping(
            value, FAULT_KINDS, "unknown fault {!r}; the faults are: " + ", ".join(FAULT_KINDS)
        )
        if isinstance(value, dict):
            value = {k: _fault_setting(v) for k, v in value.items()}
        return value

    @model_validator(mode="after")
    def _options(self) -> FaultsSection:
        for name, setting in self.active().items():
            options = FAULT_KINDS[name].options
            if setting.option is not None and setting.option not in options:
                raise ValueError(
                    f"{name}.option {setting.option!r} is not one of: "
                    + (", ".join(options) or "none (this fault takes no option)")
                )
        return self

    def active(self) -> dict[str, FaultSetting]:
        """The faults set, by name."""
        return {
            name: setting
            for name in type(self).model_fields
            if (setting := getattr(self, name)) is not None
        }
