"""The RAPID lexer: a module's text (a file's bytes checked to be text, not an encrypted or
binary module) cut into tokens (names, numbers, strings, operators; blanks and comments
dropped), and RAPID's reserved words. scenarios.rapid.parser parses the tokens.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from scenarios.rapid.syntax import EncryptedModuleError, RapidError, location


def _words(text: str) -> frozenset[str]:
    return frozenset(text.split())


# RAPID's reserved words (not names of data or instructions).
RESERVED = _words(
    "ALIAS AND BACKWARD CASE CONNECT CONST DEFAULT DIV DO ELSE ELSEIF ENDFOR ENDFUNC ENDIF "
    "ENDMODULE ENDPROC ENDRECORD ENDTEST ENDTRAP ENDWHILE ERROR EXIT FALSE FOR FROM FUNC GOTO "
    "IF INOUT LOCAL MOD MODULE NOSTEPIN NOT NOVIEW OR PERS PROC RAISE READONLY RECORD RETRY "
    "RETURN STEP SYSMODULE TASK TEST THEN TO TRAP TRUE TRYNEXT UNDO VAR VIEWONLY WHILE WITH "
    "XOR"
)
# Words that open or close a routine or a block: a statement never starts with one.
BLOCK_WORDS = _words(
    "MODULE ENDMODULE PROC ENDPROC FUNC ENDFUNC TRAP ENDTRAP RECORD ENDRECORD ENDIF ELSE "
    "ELSEIF ENDFOR ENDWHILE ENDTEST CASE DEFAULT BACKWARD ERROR UNDO THEN DO"
)


# ---------------------------------------------------------------------------------------------
# Tokens


@dataclass(frozen=True)
class Token:
    """A token: its kind, its text, its span start:end in the module's text and its line."""

    kind: str  # "name", "num", "str", "op" or "eof"
    text: str
    start: int
    end: int
    line: int

    def word(self) -> str:
        """The upper-case text of a name (RAPID's keywords are case-insensitive), else ""."""
        return self.text.upper() if self.kind == "name" else ""

    def describe(self) -> str:
        return "the end of the file" if self.kind == "eof" else f"{self.text!r} at line {self.line}"


_TOKEN = re.compile(
    r"(?P<space>[ \t\r\n\f\v\ufeff]+)"
    r"|(?P<comment>![^\n]*)"
    r"|(?P<num>0[xX][0-9A-Fa-f]+|0[bB][01]+|0[oO][0-7]+|(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)"
    r"|(?P<name>[A-Za-z_][A-Za-z0-9_]*)"
    r'|(?P<str>"(?:[^"\\\n]|""|\\.)*")'
    r"|(?P<op>:=|<>|<=|>=|[\[\](){},;:\\.+\-*/<>=%?|])"
)


def tokenize(text: str, source: str | None) -> list[Token]:
    """The tokens of `text`, ending with an "eof" token; raises RapidError naming `source`
    and the line at an unterminated string, a character RAPID does not use, or a name that
    starts with a digit."""
    tokens, pos, line = [], 0, 1
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if m is None:
            what = "unterminated string" if text[pos] == '"' else f"unexpected {text[pos]!r}"
            raise RapidError(f"{location(source, line)}: {what}")
        kind = m.lastgroup
        assert kind is not None
        if kind == "num" and re.match(r"[A-Za-z_]", text[m.end() : m.end() + 1]):
            word = re.match(r"\w+", text[pos:])
            assert word is not None
            raise RapidError(
                f"{location(source, line)}: the name {word.group()!r} starts with a digit (a "
                "RAPID name starts with a letter)"
            )
        if kind not in ("space", "comment"):
            tokens.append(Token(kind, m.group(), m.start(), m.end(), line))
        line += m.group().count("\n")
        pos = m.end()
    tokens.append(Token("eof", "", len(text), len(text), line))
    return tokens


# Characters no RAPID text holds (C0 and C1 controls other than blanks), as Latin-1 decodes
# the bytes of a binary or encrypted file.
_CONTROL = re.compile(r"[\x00-\x08\x0e-\x1f\x7f-\x9f]")
_TEXT_SAMPLE = 4096


def check_text(text: str, label: str | None) -> None:
    """Refuse a file that is not text: a controller's encrypted module or any binary file
    (a NUL, more than 1 control character in 200, or a first character that is not printable
    ASCII, where RAPID starts with MODULE, '%%%' or a comment)."""
    sample = text[:_TEXT_SAMPLE]
    first = sample.lstrip(" \t\r\n\f\v\ufeff")[:1]
    controls = len(_CONTROL.findall(sample))
    if (
        "\x00" in sample
        or controls > max(2, len(sample) // 200)
        or (first and not (first.isascii() and first.isprintable()))
    ):
        raise EncryptedModuleError(
            f"{label or 'the module'} is encrypted or binary, not RAPID text (an encrypted "
            "module can only be loaded by a controller)"
        )


def read_text(path: Path) -> str:
    """The file's text as it is (line endings kept): UTF-8, else Latin-1; refuses a binary or
    encrypted file."""
    raw = path.read_bytes()
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
    check_text(text, str(path))
    return text
