"""How `twincell --help` shows the commands, as users of click-based tools read them.

typer's help prints a type beside every parameter (`<str>`, `<bool>`, `<list[str]>`) and a
required argument in braces (`{data}...`). Here an argument is shown by its metavar alone,
as click shows it (`DATA... MODEL`, an optional one `[JOB]`), and a flag (`--quiet`,
`--help`) by its name alone: what a flag takes is nothing. The commands' classes
(`TwincellGroup` for the app, `TwincellCommand` for each command) give their parameters
these forms. A command declares its parameters with `argument`, `option` and `flag`: each
with its metavar (PATH, INTEGER, `[m|mm]`; none for a flag) and its help panel. `example`
writes a command's "Example:" epilog.
"""

from __future__ import annotations

from typing import Any

import typer
from typer import _click
from typer.core import TyperArgument, TyperCommand, TyperGroup, TyperOption


def argument(metavar: str, help: str, **checks: Any) -> Any:
    """A command's argument, shown as `metavar` (DATA..., MODEL); `checks` are those of
    typer.Argument (exists, dir_okay, ...)."""
    return typer.Argument(metavar=metavar, help=help, **checks)


def option(name: str, metavar: str, help: str, panel: str | None = None, **checks: Any) -> Any:
    """An option that takes a value, shown as `metavar` (PATH, INTEGER, `[m|mm]`) in the help
    panel `panel` (None: the Options panel); `checks` are those of typer.Option (min,
    exists, dir_okay, ...)."""
    return typer.Option(name, metavar=metavar, help=help, rich_help_panel=panel, **checks)


def flag(name: str, help: str, panel: str | None = None) -> Any:
    """A flag (an option that takes no value) in the help panel `panel`."""
    return typer.Option(name, help=help, rich_help_panel=panel)


class NamedArgument(TyperArgument):
    """An argument shown by its metavar (DATA..., MODEL, [JOB]), with no type beside it."""

    def display_type_rich(self, ctx: _click.Context) -> str | None:
        return None

    def get_usage_pieces(self, ctx: _click.Context) -> list[str]:
        name = self.display_name_raw
        return [name if self.required else f"[{name}]"]


class Flag(TyperOption):
    """A flag (an option that takes no value), shown by its name alone."""

    def display_type_rich(self, ctx: _click.Context) -> str | None:
        return None


def readable(param: _click.Parameter) -> _click.Parameter:
    """`param` in its readable form: an argument with a metavar as a NamedArgument, a flag
    as a Flag (typer makes the parameters; their class is all that changes)."""
    if type(param) is TyperArgument and param.metavar is not None:
        param.__class__ = NamedArgument
    elif type(param) is TyperOption and param.is_flag:
        param.__class__ = Flag
    return param


class TwincellCommand(TyperCommand):
    """A `twincell` command, its parameters in their readable form (`readable`)."""

    def get_params(self, ctx: _click.Context) -> list[_click.Parameter]:
        return [readable(param) for param in super().get_params(ctx)]


class TwincellGroup(TyperGroup):
    """The `twincell` app, its own options (--version, --help) in their readable form."""

    def get_params(self, ctx: _click.Context) -> list[_click.Parameter]:
        return [readable(param) for param in super().get_params(ctx)]


def example(*command_lines: str) -> str:
    """A command's epilog: "Example:" and the command lines (Markdown, as the help is)."""
    heading = "Example:" if len(command_lines) == 1 else "Examples:"
    return "\n\n".join([f"**{heading}**", *(f"`{line}`" for line in command_lines)])
