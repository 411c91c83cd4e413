"""The documentation: the site builds with ``mkdocs build --strict`` (a broken link, anchor or
reference fails it), its reference pages come from the code, and the pages stay readable: a
short README, no page over 500 lines but the generated ones, each page opening with a summary of
what it answers, and no numbers of old fixes or issues in place of an explanation."""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
#: History by number (the word fix or issue and a number): the pages say instead what a rule
#: protects against, and CHANGELOG.md keeps the story.
HISTORY = re.compile(r"(fix|issue) ?#?[0-9]+", re.IGNORECASE)


def _hooks():
    spec = importlib.util.spec_from_file_location("docs_hooks", ROOT / "scripts" / "docs_hooks.py")
    hooks = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(hooks)
    return hooks


def option_is_help(action) -> bool:
    return "-h" in action.option_strings


def _pages() -> list[Path]:
    """The written pages of docs/ (the generated ones, committed beside them, left out)."""
    generated = set(_hooks().generated_pages())
    return sorted(p for p in DOCS.rglob("*.md")
                  if p.relative_to(DOCS).as_posix() not in generated)


def test_the_site_builds_strictly(tmp_path: Path) -> None:
    """``make docs``: every page, link, anchor and API reference resolves (about 10 s)."""
    site = tmp_path / "site"
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir",
                           str(site)], cwd=ROOT, capture_output=True, text=True,
                          env={**os.environ, "NO_MKDOCS_2_WARNING": "1"})
    assert done.returncode == 0, done.stderr[-4000:]
    for page in ("reference/fmu-variables", "reference/cli", "reference/errors",
                 "reference/limits", "reference/table-columns", "reference/api",
                 "measurements", "explanation/robustness/flights"):
        assert (site / page / "index.html").exists(), page
    api = (site / "reference" / "api" / "index.html").read_text()
    assert "advance" in api and "load_scene" in api  # mkdocstrings rendered the docstrings


def test_the_reference_pages_come_from_the_code() -> None:
    """The variables are the contracts' tables, the command line is the parser's (every option of
    every command), the errors page has a message for every variable and the limits page every
    constant of iceimpact.limits."""
    from iceimpact import contract, limits
    from iceimpact.cli import build_parser
    from iceimpact.modal import contract as modal

    hooks = _hooks()
    variables = hooks.fmu_variables_page()
    assert contract.markdown_table() in variables and modal.markdown_table() in variables
    cli = hooks.cli_page()
    parser = build_parser()
    for name, sub in hooks._subparsers(parser).items():
        assert f"## iceimpact {name}" in cli
        for action in sub._actions:
            for option in [] if option_is_help(action) else action.option_strings:
                assert f"`{option}`" in cli, (name, option)
    errors = hooks.errors_page()
    for var in (*contract.PARAMETERS, *contract.INPUTS):
        assert f"| `{var.name}` |" in errors, var.name
    assert errors.count("is not allowed") > len(contract.PARAMETERS) + len(hooks.SCENE_CASES)
    limits_page = hooks.limits_page()
    for name in ("TIME_RESOLUTION", "OMEGA_MAX_EXACT", "DRAG_RATE_MAX", "TAYLOR_RATE_MAX",
                 "ODE_EXPLICIT_RATE_MAX", "RADAU_RTOL_MIN"):
        assert f"`{name}`" in limits_page and hasattr(limits, name)


def test_every_measurement_has_a_page() -> None:
    """Every table and JSON file under benchmarks/results/ is a page (or a file) of the site, with
    the command that writes it."""
    pages = _hooks().measurement_pages()
    results = ROOT / "benchmarks" / "results"
    for path in [*results.glob("*.md"), *results.glob("*.json")]:
        assert f"measurements/{path.name}" in pages, path.name


def test_the_readme_is_short_and_starts_with_the_two_commands() -> None:
    text = (ROOT / "README.md").read_text()
    lines = text.splitlines()
    assert len(lines) <= 150, len(lines)
    head = "\n".join(lines[:20])
    assert "make demo" in head and "make test" in head
    assert "docs/img/" in text  # one picture


@pytest.mark.parametrize("path", _pages(), ids=lambda p: str(p.relative_to(DOCS)))
def test_each_page_is_short_and_opens_with_a_summary(path: Path) -> None:
    """At most 500 lines (the generated reference pages are not files of docs/), a title, then a
    paragraph of two sentences that says what the page answers."""
    text = path.read_text()
    assert len(text.splitlines()) <= 500
    blocks = [b.strip() for b in text.split("\n\n") if b.strip()]
    assert blocks[0].startswith("# ") and "\n" not in blocks[0], blocks[0][:80]
    summary = " ".join(blocks[1].split())
    assert not summary.startswith(("|", "```", "#", "-", "*", "!", "<")), summary[:80]
    sentences = [s for s in re.split(r"(?<=[.!?])\s+(?=[A-Z`*\[])", summary) if s]
    assert len(sentences) == 2 and summary.endswith((".", ")")), summary


def test_no_history_numbers_in_the_readme_the_docs_and_the_tests() -> None:
    files = [ROOT / "README.md", *_pages(), *(ROOT / "tests").rglob("*.py")]
    found = [f"{path.relative_to(ROOT)}: {m.group(0)}" for path in files
             for m in HISTORY.finditer(path.read_text())]
    assert not found, found
