"""What a user is told about the project's identity is what they get: ``iceimpact --version``
prints the contract's version, CITATION.cff carries the same version, licence and authors as
the contract and pyproject.toml, and LICENSE is the MIT text the contract names."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from iceimpact import contract
from iceimpact.cli import main

ROOT = Path(__file__).resolve().parents[1]


def test_version_option_prints_the_contract_version(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["--version"])
    assert exit_info.value.code == 0
    assert capsys.readouterr().out == f"iceimpact {contract.VERSION}\n"


def test_version_option_of_the_module_command() -> None:
    """The same through a fresh interpreter, as the installed command runs it."""
    done = subprocess.run([sys.executable, "-m", "iceimpact.cli", "--version"],
                          capture_output=True, text=True, timeout=60,
                          env={"PYTHONPATH": str(ROOT / "fmu_src"), "PATH": ""})
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == f"iceimpact {contract.VERSION}"


def test_citation_file_agrees_with_the_contract() -> None:
    yaml = pytest.importorskip("yaml")
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    assert cff["cff-version"] == "1.2.0"
    assert cff["title"] == "IceImpact"
    assert str(cff["version"]) == contract.VERSION
    assert cff["license"] == contract.LICENSE
    assert cff["authors"] == [{"name": contract.AUTHOR}]
    assert cff["message"]
    (article,) = cff["references"]
    assert article["type"] == "article"
    assert article["title"] == "Vibrations due to Flow-Driven Repeated Impacts"
    assert article["authors"]  # required by the CFF schema


def test_licence_is_the_one_declared_everywhere() -> None:
    with open(ROOT / "pyproject.toml", "rb") as fh:
        project = tomllib.load(fh)["project"]
    assert project["license"] == contract.LICENSE == "MIT"
    assert project["license-files"] == ["LICENSE"]
    assert project["authors"] == [{"name": contract.AUTHOR}]
    text = (ROOT / "LICENSE").read_text()
    assert text.startswith("MIT License\n")
    assert f"Copyright (c) 2026 {contract.AUTHOR}" in text
    assert "THE SOFTWARE IS PROVIDED \"AS IS\"" in text
