"""The tables of FMU variables fit their page, on the site and inside each FMU: what can be checked
without a browser. ``make look`` (scripts/look_at_docs.py) measures the laid-out pages in
Chromium; these tests hold the rules it relies on: one stylesheet keeps a variable's name on one
line and lets the meaning column wrap, the site loads it, the generated page puts both tables
under it and gives them the room of the table of contents, and each FMU's page carries it inline
around its table."""

from __future__ import annotations

import importlib
import importlib.util
import re
import sys
from pathlib import Path

import pytest

from fmu_host import build_module

ROOT = Path(__file__).resolve().parents[2]
CSS = ROOT / "docs" / "stylesheets" / "variables.css"
#: The declarations each rule must carry: the name never broken, the meaning wrapped.
NAME_RULE = (".variables td:first-child code",
             {"white-space": "nowrap", "word-break": "normal", "overflow-wrap": "normal"})
MEANING_RULE = (".variables td:last-child", {"overflow-wrap": "anywhere"})


def _load(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # before it runs: its dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


def _rules(css: str) -> dict[str, dict[str, str]]:
    """selector -> {property: value} of a stylesheet without nesting (comments dropped)."""
    css = re.sub(r"/\*.*?\*/", "", css, flags=re.DOTALL)
    rules: dict[str, dict[str, str]] = {}
    for selectors, body in re.findall(r"([^{}]+)\{([^{}]*)\}", css):
        declarations = dict((p.strip(), v.strip()) for p, _, v in
                            (d.partition(":") for d in body.split(";") if d.strip()))
        for selector in selectors.split(","):
            rules.setdefault(" ".join(selector.split()), {}).update(declarations)
    return rules


def _documentation():
    """fmu_build.documentation of this checkout, loaded as build_fmu.py loads its package."""
    return importlib.import_module(build_module().build_package().__name__ + ".documentation")


@pytest.mark.parametrize(("selector", "wanted"), [NAME_RULE, MEANING_RULE])
def test_the_stylesheet_keeps_names_whole_and_wraps_the_meaning(selector, wanted) -> None:
    rule = _rules(CSS.read_text()).get(selector)
    assert rule is not None, f"{CSS.name} has no rule for {selector}"
    for prop, value in wanted.items():
        assert rule.get(prop) == value, f"{selector} {{ {prop}: {value} }} missing"


def test_the_rules_read_as_written() -> None:
    """The stylesheet reader above, on a sheet that lacks the rule (so the tests can fail)."""
    rules = _rules("/* a */ .variables td:first-child code, th { white-space: normal; }\n"
                   "td { color: red }")
    assert rules[NAME_RULE[0]] == {"white-space": "normal"}
    assert rules["th"] == {"white-space": "normal"} and rules["td"] == {"color": "red"}


def test_the_site_loads_the_stylesheet() -> None:
    from mkdocs.config import load_config

    config = load_config(str(ROOT / "mkdocs.yml"))
    assert CSS.relative_to(config["docs_dir"]).as_posix() in config["extra_css"]


def test_the_variables_page_puts_its_tables_under_the_stylesheet() -> None:
    """Both tables are in ``<div class="variables" markdown>``, and the page hides its table of
    contents, whose width the seven columns need at 1280 px."""
    page = _load("docs_hooks", ROOT / "scripts" / "docs_hooks.py").fmu_variables_page()
    assert page.startswith("---\nhide:\n  - toc\n---\n")
    blocks = re.findall(r'<div class="variables" markdown>\n\n(.*?)\n</div>', page, re.DOTALL)
    assert len(blocks) == 2
    headers = [line for line in page.splitlines() if line.startswith("| name |")]
    assert len(headers) == 2 and all(any(h in b for b in blocks) for h in headers)
    for block in blocks:  # a whole table in each: every line a row
        assert all(line.startswith("|") for line in block.strip().splitlines())


@pytest.mark.parametrize("fmi_version", ["2.0", "3.0"])
@pytest.mark.parametrize("model", ["IceImpact", "ModalStructure"])
def test_each_fmus_page_carries_the_stylesheet(model: str, fmi_version: str) -> None:
    """The page inside the FMU is read offline: the rules are inline, around its one table, which
    scrolls rather than widen the page."""
    page = _documentation().documentation_page(model, fmi_version, standalone=False)
    style = page.split("<style>", 1)[1].split("</style>", 1)[0]
    assert CSS.read_text().strip() in style
    assert _rules(style)["div.variables"] == {"overflow-x": "auto"}
    assert re.search(r'<div class="variables">\n<table>.*?</table>\n</div>', page, re.DOTALL)
    assert page.count("<table>") == 1


def test_the_look_script_refuses_what_it_cannot_look_at(tmp_path: Path, capsys) -> None:
    """scripts/look_at_docs.py builds nothing: a missing site is an argument error (status 2), and
    without a browser it says what to install (status 2), before it opens anything."""
    look = _load("look_at_docs", ROOT / "scripts" / "look_at_docs.py")
    with pytest.raises(SystemExit) as exc:
        look.main([str(tmp_path / "no-site"), str(tmp_path / "no.fmu")])
    assert exc.value.code == 2 and "build the site first" in capsys.readouterr().err
    for page in look.SITE_PAGES.values():
        (tmp_path / "site" / page).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / "site" / page).write_text("<html></html>")
    (tmp_path / "x.fmu").write_bytes(b"")
    code = look.main([str(tmp_path / "site"), str(tmp_path / "x.fmu"),
                      "--chromium", str(tmp_path / "no-chromium")])
    assert code == 2 and "apt-get install chromium" in capsys.readouterr().err
