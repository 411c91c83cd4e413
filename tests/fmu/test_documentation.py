"""What a user reads is what the FMU has: documentation/index.html inside every FMU (FMI 2.0 and
3.0, default and standalone, IceImpact and ModalStructure) lists every variable of its contract
with its unit, says how to run it, its limits and its licence, laid out by the site's stylesheet
of variables tables; FMPy's validator still finds nothing; and the compatibility box of README.md
and docs/index.md is the one the build writes."""

from __future__ import annotations

import html
import importlib
import re
import zipfile
from pathlib import Path

import pytest
from fmpy.validation import validate_fmu

from fmu_host import build_module
from iceimpact import contract
from iceimpact.modal import contract as modal_contract

ROOT = Path(__file__).resolve().parents[2]
PAGE = "documentation/index.html"


def _compatibility():
    """fmu_build.compatibility of this checkout, loaded as build_fmu.py loads its package."""
    return importlib.import_module(build_module().build_package().__name__ + ".compatibility")


def _page(fmu: Path) -> str:
    with zipfile.ZipFile(fmu) as zf:
        return zf.read(PAGE).decode()


def _rows(page: str) -> dict[str, list[str]]:
    """The variables table of the page: name -> its cells, as text."""
    rows = {}
    for row in re.findall(r"<tr>(.*?)</tr>", page):
        cells = [html.unescape(re.sub(r"<[^>]+>", "", c))
                 for c in re.findall(r"<td>(.*?)</td>", row)]
        if cells:
            rows[cells[0]] = cells
    return rows


def _check_page(page: str, table, fmi_version: str, standalone: bool) -> None:
    types = ({float: "Real", int: "Integer", bool: "Boolean"} if fmi_version == "2.0"
             else {float: "Float64", int: "Int32", bool: "Boolean"})
    rows = _rows(page)
    assert len(rows) == len(table.VARIABLES)
    for v in table.VARIABLES:
        name, causality, variability, kind, unit, start, allowed, meaning = rows[v.name]
        assert (causality, variability, kind) == (v.causality, v.variability, types[v.kind])
        assert unit == (v.unit or "–"), v.name
        assert start == ("" if v.start is None else contract.number_text(v.start)), v.name
        assert (allowed, meaning) == (v.allowed, v.description), v.name
    text = html.unescape(page)
    assert f"FMI {fmi_version} Co-Simulation, version {table.VERSION}" in text
    assert table.DESCRIPTION in text
    assert "from fmpy import simulate_fmu" in text
    assert "Linux x86_64 only" in text
    assert ("standalone</b> build" in text) == standalone
    assert "Python 3.11, 3.12 or 3.13" in text or standalone
    assert "MIT License" in text and f"Copyright (c) 2026 {contract.AUTHOR}" in text
    assert "<script" not in page and "http" not in page  # self-contained
    # the site's layout rules, inline: names unbroken, the meaning wrapped (test_page_layout.py)
    assert (ROOT / "docs" / "stylesheets" / "variables.css").read_text().strip() in page
    assert '<div class="variables">\n<table>' in page


def test_the_fmi2_fmu_documents_every_variable(fmu):
    _check_page(_page(fmu), contract, "2.0", standalone=False)
    assert validate_fmu(str(fmu)) == []


def test_the_fmi3_fmu_documents_every_variable(fmu3):
    page = _page(fmu3)
    _check_page(page, contract, "3.0", standalone=False)
    assert "IceImpact3.fmu" in page and "early_return_allowed=True" in page
    assert validate_fmu(str(fmu3)) == []


def test_the_standalone_fmus_say_they_bring_their_python(standalone_fmu, standalone_fmu3):
    _check_page(_page(standalone_fmu), contract, "2.0", standalone=True)
    _check_page(_page(standalone_fmu3), contract, "3.0", standalone=True)
    assert validate_fmu(str(standalone_fmu3)) == []


def test_the_modal_structure_fmu_documents_its_contract(fmus):
    modal = fmus / "ModalStructure.fmu"
    _check_page(_page(modal), modal_contract, "2.0", standalone=False)
    assert validate_fmu(str(modal)) == []


def test_the_page_is_written_once_per_fmu(fmu, fmu3):
    for path in (fmu, fmu3):
        with zipfile.ZipFile(path) as zf:
            assert zf.namelist().count(PAGE) == 1


@pytest.mark.parametrize(("name", "link_root"), [("README.md", "docs/"), ("docs/index.md", "")])
def test_the_compatibility_box_is_the_builds(name: str, link_root: str) -> None:
    """README.md and docs/index.md hold the same facts (``python -m fmu_build.compatibility``
    rewrites them), and the box states the FMI versions, the platform and the masters."""
    compatibility = _compatibility()
    box = compatibility.markdown_box(link_root)
    text = (ROOT / name).read_text()
    assert box in text, f"run: python -m fmu_build.compatibility ({name} differs)"
    for fact in ("2.0 Co-Simulation (`IceImpact.fmu`)", "3.0 Co-Simulation (`IceImpact3.fmu`)",
                 "Linux x86_64 only", "3.11, 3.12 or 3.13", "early_return_allowed=True",
                 "--early-return-allowed", "`coupling.scheme = 2`", "libcosim"):
        assert fact in box, fact
