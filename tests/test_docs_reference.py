"""The documentation's hand-written reference agrees with the code: every field a run writes
into results.json is on docs/reference/results.md, every exit status the command returns is
on docs/reference/statuses.md (and no other), the README's pictures are the files
docs/make_figures.py makes, and its links lead to files. (The command and configuration
references are generated from the code when the site is built.)"""

from __future__ import annotations

import json
import re
import signal
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"


def _documented(page: Path) -> set[str]:
    return set(re.findall(r"`([A-Za-z_][\w]*)`", page.read_text()))


def test_every_results_field_is_documented(short_skull_run: Path) -> None:
    results = json.loads((short_skull_run / "results.json").read_text())
    page = DOCS / "reference" / "results.md"
    documented = _documented(page)
    missing = {key for key in results if key not in documented}
    for key, value in results.items():
        items = value if isinstance(value, list) else [value]
        for item in items[:1]:
            if isinstance(item, dict) and key != "methods":
                missing |= {f"{key}.{k}" for k in item if k not in documented}
    for method in results["methods"].values():
        missing |= {f"methods.*.{k}" for k in method if k not in documented}
    assert not missing, f"results.json fields not on {page.name}: {sorted(missing)}"


def _exit_statuses_in_code() -> set[int]:
    """The exit statuses the commands (scenarios/cli/*_command.py) and the command line's
    ending (scenarios/cli/exit_status.py) give."""
    cli = ROOT / "scenarios" / "cli"
    commands = "\n".join(path.read_text() for path in sorted(cli.glob("*_command.py")))
    found = {int(n) for n in re.findall(r"Exit\((\d+)", commands)}
    found |= {int(n) for n in re.findall(r"Exit\(\d+ if .* else (\d+)\)", commands)}
    ending = (cli / "exit_status.py").read_text()
    ending = ending[ending.index("def run_command_line(") :]
    found |= {int(n) for n in re.findall(r"return (\d+)\b", ending)}
    # A run stopped by a signal: 128 + the signal's number (scenarios.jobs.interrupt).
    found |= {128 + signal.SIGINT, 128 + signal.SIGTERM}
    return found


def test_exit_statuses_are_documented() -> None:
    page = (DOCS / "reference" / "statuses.md").read_text()
    table = page[page.index("## Exit codes") :]
    documented = {int(n) for n in re.findall(r"^\| (\d+) \|", table, re.MULTILINE)}
    assert documented == _exit_statuses_in_code(), (documented, _exit_statuses_in_code())
    for status in ("complete", "refused", "aborted", "incomplete"):
        assert f"`{status}`" in page, status


def test_the_readme_pictures_are_the_figures_script_s() -> None:
    import importlib.util

    spec = importlib.util.spec_from_file_location("make_figures", DOCS / "make_figures.py")
    assert spec is not None and spec.loader is not None
    figures = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(figures)
    readme = (ROOT / "README.md").read_text()
    home = (DOCS / "index.md").read_text()
    for name in figures.FIGURES:
        path = figures.ASSETS / name
        assert path.is_file() and path.stat().st_size > 10_000, path
        assert f"docs/assets/{name}" in readme and f"assets/{name}" in home, name


def test_the_readme_links_lead_to_files() -> None:
    """The README is read on its own (GitHub, PyPI): each relative link and picture must
    lead to a file of the repository (the site's own links are checked by mkdocs --strict)."""
    readme = (ROOT / "README.md").read_text()
    targets = re.findall(r"\]\(([^)\s]+)\)", readme) + re.findall(r'src="([^"]+)"', readme)
    local = [t.split("#")[0] for t in targets if "://" not in t]
    assert len(local) >= 10, local
    missing = [t for t in local if not (ROOT / t).exists()]
    assert not missing, missing


def test_the_pages_snippets_include_files_that_exist() -> None:
    """Every line that starts like a snippet (`--8<--`, pymdownx.snippets) is one, written so
    that the site includes the file (a code formatter once spaced one out into
    `--8 < --"..."`, which the site then printed as text), and names a file that exists."""
    for page in sorted((ROOT / "docs").rglob("*.md")):
        for number, line in enumerate(page.read_text().splitlines(), 1):
            if line.lstrip().startswith("--8"):
                found = re.fullmatch(r'\s*--8<-- "([^"]+)"', line)
                assert found is not None, f"{page.name}:{number}: {line!r}"
                assert (ROOT / found.group(1)).is_file(), f"{page.name}:{number}: {line!r}"
