"""Pages made when the site is built (mkdocs-gen-files): the configuration keys from the job
configuration's pydantic schema, and the benchmarks' figures from bench/data."""

from __future__ import annotations

import re
import types
import typing
from pathlib import Path

import annotated_types
import mkdocs_gen_files
from pydantic import BaseModel
from pydantic.fields import FieldInfo

import scenarios.configuration as config_module
from scenarios.configuration.job_config import JobConfig

ROOT = Path(__file__).resolve().parent.parent

#: A key's unit, from its name's suffix (SI inside: the name says where it is not); the
#: longer suffixes first.
UNITS = (
    ("_nm_rad", "N m/rad"), ("_m_s", "m/s"), ("_deg_s", "deg/s"), ("_rad_per_s", "rad/s"),
    ("_rad_s", "rad/s"), ("_per_s", "1/s"), ("_nm", "N m"), ("_mm", "mm"),
    ("_deg", "deg"), ("_rad", "rad"), ("_hu", "HU"), ("_m", "m"), ("_s", "s"),
    ("_kg", "kg"), ("_n", "N"), ("_hz", "Hz"),
)  # fmt: skip


def unit(name: str) -> str:
    return next((u for suffix, u in UNITS if name.endswith(suffix)), "")


def type_name(annotation: object) -> str:
    text = getattr(annotation, "__name__", None) if isinstance(annotation, type) else None
    if text is None:
        text = repr(annotation)
    text = re.sub(r"\b(typing|pathlib|builtins|[\w.]+\.)(?=[A-Z]\w*|Literal|Any)", "", text)
    return text.replace("NoneType", "None").replace("typing.", "")


def default_text(info: FieldInfo) -> str:
    if info.is_required():
        return "required"
    value = info.get_default(call_default_factory=True)
    if isinstance(value, BaseModel):
        return "(section)"
    return f"`{value!r}`" if value is not None else "`None`"


def bounds(info: FieldInfo) -> str:
    found = []
    for item in info.metadata:
        for attr, sign in (("ge", ">="), ("gt", ">"), ("le", "<="), ("lt", "<")):
            if isinstance(item, getattr(annotated_types, attr.capitalize())):
                found.append(f"{sign} {getattr(item, attr)}")
    return ", ".join(found)


def sections(model: type[BaseModel], path: str) -> typing.Iterator[tuple[str, type[BaseModel]]]:
    yield path, model
    for name, info in model.model_fields.items():
        for sub in _models_in(info.annotation):
            yield from sections(sub, f"{path}.{name}" if path else name)


def _models_in(annotation: object) -> list[type[BaseModel]]:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    if isinstance(annotation, types.UnionType) or typing.get_origin(annotation) is typing.Union:
        return [m for arg in typing.get_args(annotation) for m in _models_in(arg)]
    return []


def config_page() -> str:
    lines = [
        "# Configuration keys",
        "",
        "Every key of a job's YAML (and of a cell file's `cell:` keys), read from the job",
        "configuration's schema (`scenarios.configuration.job_config.JobConfig`, pydantic)",
        "when this site is built. A key is given in a YAML file or on the command line as a",
        "dotted key: `twincell run skull --set cell.noise.laser_sigma_m=2e-4`. An unknown key",
        "or a value out of range is refused, naming the key and the keys valid there. Units",
        "follow the key's name: `_m` metres, `_rad` radians, `_deg` degrees, `_s` seconds; the",
        "rest is SI.",
        "",
    ]
    for path, model in sections(JobConfig, ""):
        doc = " ".join((model.__doc__ or "").split())
        if not path:  # the top level: the sections, as the configuration's module lists them
            doc = (config_module.__doc__ or "").split("\n\n")[1].replace(":\n- ", ":\n\n- ", 1)
        lines += [f"## `{path or 'top level'}`", ""] + ([doc, ""] if doc else [])
        lines += ["| key | type | default | unit | range |", "|---|---|---|---|---|"]
        for name, info in model.model_fields.items():
            kind = type_name(info.annotation).replace(" | ", " or ")
            default = default_text(info).replace("|", "/")
            row = [f"`{name}`", f"`{kind}`", default, unit(name), bounds(info)]
            lines.append("| " + " | ".join(row) + " |")
        lines.append("")
    return "\n".join(lines)


def cell_numbers_page() -> str:
    """The cell's frames and numbers for the shipped skull job, on the built-in arm and on the
    UR5 cell, from the code that builds the cell (scenarios.jobs.cell_numbers)."""
    from scenarios.configuration.config_files import load_config
    from scenarios.jobs.cell_numbers import cell_numbers, numbers_markdown

    parts = [
        "# The cell's frames and numbers\n",
        "What a program written offline for twincell's cell needs, read from the code that "
        "builds the cell when this site is built (`twincell author JOB --numbers` prints them "
        "for your job and cell; `twincell author JOB --touch ...` writes the work object, "
        "the tool's data and the touches: [Your RAPID program](../tutorials/program.md)). "
        "The cell frame is the built-in arm's base frame: x towards the table, z up "
        "(RAPID's base frame for an arm mounted there); lengths in mm, quaternions "
        "scalar first as RAPID writes them.\n",
    ]
    for title, cell in (("The skull job, built-in arm", None), ("The skull job, UR5 cell", "ur5")):
        parts += [f"## {title}\n", numbers_markdown(cell_numbers(load_config("skull", None, cell)))]
    return "\n".join(parts)


with mkdocs_gen_files.open("reference/cell-numbers.md", "w") as page:
    page.write(cell_numbers_page())

with mkdocs_gen_files.open("reference/config.md", "w") as page:
    page.write(config_page())
for figure in sorted((ROOT / "bench" / "data").glob("*.png")):
    with mkdocs_gen_files.open(f"assets/bench/{figure.name}", "wb") as out:
        out.write(figure.read_bytes())
