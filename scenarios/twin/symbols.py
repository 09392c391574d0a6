"""RAPID data of the loaded modules as RWS reads and writes them (`rw/rapid/symbol/data/RAPID/
T_ROB1[/MODULE]/NAME`): a module-level datum's value as RAPID text, written back into its
module's text (scenarios.rapid.module.with_value) after checking that it has the shape of its
type (num, bool, string, robtarget, jointtarget, records and arrays of them). CONST data are
read-only, as on a controller."""

from __future__ import annotations

import re
from dataclasses import dataclass

from scenarios.rapid.module import Declaration, RapidModule, with_value
from scenarios.rapid.reader import read_module
from scenarios.rapid.syntax import RapidError
from scenarios.twin.controller_errors import ControllerError, bad_request, forbidden, not_found

_NINE = "9E+09"
#: The value a datum declared without one has, by type.
DEFAULTS = {
    "num": "0",
    "dnum": "0",
    "bool": "FALSE",
    "string": '""',
    "robtarget": "[[0,0,0],[1,0,0,0],[0,0,0,0],[" + ",".join([_NINE] * 6) + "]]",
    "jointtarget": "[[0,0,0,0,0,0],[" + ",".join([_NINE] * 6) + "]]",
}
#: RWS's symbol types: storage -> symtyp.
SYMTYP = {"PERS": "per", "VAR": "var", "CONST": "con"}


@dataclass(frozen=True)
class Symbol:
    """A module-level datum of a loaded module."""

    module: RapidModule
    declaration: Declaration

    @property
    def url(self) -> str:
        return f"RAPID/T_ROB1/{self.module.name}/{self.declaration.name}"

    @property
    def value(self) -> str:
        """The value as RWS gives it: RAPID text without blanks (strings kept whole)."""
        d = self.declaration
        if d.text is None:
            return DEFAULTS.get(d.datatype.lower(), "[]")
        return _compact(d.text)


def _compact(text: str) -> str:
    parts = re.split(r'("(?:[^"]|"")*")', text)
    return "".join(p if p.startswith('"') else re.sub(r"\s+", "", p) for p in parts)


def find(modules: list[RapidModule], path: str) -> Symbol:
    """The symbol `path` names ("T_ROB1/NAME" or "T_ROB1/MODULE/NAME", any case); ControllerError
    404 if no loaded module declares it at module level."""
    parts = [p for p in path.split("/") if p]
    if len(parts) not in (2, 3) or parts[0].upper() != "T_ROB1":
        raise bad_request(f"{path!r}: a symbol is T_ROB1/NAME or T_ROB1/MODULE/NAME")
    name = parts[-1].casefold()
    wanted = parts[1].casefold() if len(parts) == 3 else None
    for module in modules:
        if wanted is not None and module.name.casefold() != wanted:
            continue
        for decl in module.data.values():
            if decl.name.casefold() == name and (wanted is not None or decl.scope != "LOCAL"):
                return Symbol(module, decl)
    raise not_found(f"RAPID/{path}: no such symbol in the loaded modules")


def _shape(value: object) -> object:
    if isinstance(value, bool):
        return "bool"
    if isinstance(value, float | int):
        return "num"
    if isinstance(value, str):
        return "string"
    if isinstance(value, tuple):
        return tuple(_shape(v) for v in value)
    return None


def set_value(symbol: Symbol, value: str) -> str:
    """The module's new text with `symbol` set to `value`; ControllerError if the datum is
    a CONST or the value is not of its type's shape."""
    d = symbol.declaration
    if d.storage == "CONST":
        raise forbidden(f"{symbol.url}: a CONST is read-only")
    if not value.strip() or len(value) > 4096:
        raise bad_request(f"{symbol.url}: give a value of 1 to 4096 characters")
    old = d.value if d.text is not None else _default_value(d.datatype)
    try:
        text = with_value(symbol.module, d.name, value.strip())
        new = read_module(text, symbol.module.label).data[d.name]
    except (RapidError, KeyError) as exc:
        raise bad_request(f"{symbol.url}: {value!r} is not a {d.datatype}: {exc}") from None
    if old is not None and _shape(new.value) != _shape(old):
        raise bad_request(f"{symbol.url}: {value!r} does not have the shape of a {d.datatype}")
    return text


def _default_value(datatype: str) -> object:
    text = DEFAULTS.get(datatype.lower())
    if text is None:
        return None
    module = read_module(f"MODULE m\n  VAR {datatype} x := {text};\nENDMODULE\n", "default")
    return module.data["x"].value


def search(modules: list[RapidModule], symtyp: str = "any", name: str = "") -> list[Symbol]:
    """The loaded modules' module-level data of a symbol type ("per", "var", "con" or "any")
    whose name matches the regular expression `name` (any case)."""
    if symtyp not in ("per", "var", "con", "any"):
        raise bad_request(f"symtyp {symtyp!r}: give per, var, con or any")
    try:
        pattern = re.compile(name or ".*", re.I)
    except re.error as exc:
        raise bad_request(f"regexp {name!r}: {exc}") from None
    return [
        Symbol(m, d)
        for m in modules
        for d in m.data.values()
        if (symtyp == "any" or SYMTYP.get(d.storage) == symtyp) and pattern.search(d.name)
    ]


__all__ = ["ControllerError", "Symbol", "find", "search", "set_value"]
