"""Length units of mesh files: names and scale factors to metres."""

from __future__ import annotations

from models.model_errors import ModelParameterError

UNIT_SCALES = {"mm": 1e-3, "cm": 1e-2, "m": 1.0, "in": 0.0254}


def unit_scale(units: str | float) -> float:
    """Metres per file unit: a unit name ("mm", "cm", "m", "in") or a positive scale factor."""
    if isinstance(units, str):
        if units in UNIT_SCALES:
            return UNIT_SCALES[units]
        try:
            units = float(units)
        except ValueError:
            raise ModelParameterError(
                f"units must be one of {sorted(UNIT_SCALES)} or a positive scale factor "
                f"(metres per file unit), got {units!r}"
            ) from None
    if isinstance(units, bool) or not isinstance(units, int | float) or not 0 < units < 1e6:
        raise ModelParameterError(
            f"a unit scale factor must be a positive number of metres per file unit, got {units!r}"
        )
    return float(units)
