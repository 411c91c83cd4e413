"""The reproduction scripts (examples/reproduce_*.py) run end to end in their quick mode.

Each script is run as a user would, in a subprocess, with ``--quick`` (every case shortened to a
few seconds, still through IceImpact.fmu with FMPy, both solvers): it must exit with status 0,
print its tables and write one PNG per figure group and its JSON summary. The FMU is the one in
``dist/`` (built by ``build_fmu.py`` if missing).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FMU = ROOT / "dist" / "IceImpact.fmu"

SCRIPTS = {
    "reproduce_linear.py": (
        "linear_quick.json",
        ["fig02_reference_linear.png", "fig04-06_ice_mass_linear.png",
         "fig07-09_restitution_linear.png"],
    ),
    "reproduce_quadratic.py": (
        "quadratic_quick.json",
        ["fig10_free_flight.png", "fig11_flow_1.png", "fig12_flow_2.png", "fig13_area_2.png",
         "fig14-16_ice_mass_quadratic.png", "fig17-18_restitution_quadratic.png"],
    ),
}


@pytest.fixture(scope="module")
def fmu() -> Path:
    if not FMU.exists():
        subprocess.run([sys.executable, str(ROOT / "build_fmu.py")], check=True, cwd=ROOT)
    return FMU


@pytest.mark.parametrize("script", sorted(SCRIPTS))
def test_reproduction_script_quick_mode(script: str, fmu: Path, tmp_path: Path) -> None:
    summary_name, pngs = SCRIPTS[script]
    proc = subprocess.run(
        [sys.executable, str(ROOT / "examples" / script), "--quick", "--fmu", str(fmu),
         "--out", str(tmp_path)],
        capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    for png in pngs:
        path = tmp_path / png
        assert path.exists(), f"{script} did not write {png}"
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    summary = json.loads((tmp_path / summary_name).read_text())
    assert summary["quick"] is True
    assert len(summary["groups"]) == len(pngs)
    # every case ran with the exact solver and the fixed-step scheme, and the tables were printed
    for group in summary["groups"].values():
        for case in group["cases"].values():
            assert "exact" in case["runs"]
    assert "article" in proc.stdout and "exact" in proc.stdout


def test_only_selects_one_figure_group(fmu: Path, tmp_path: Path) -> None:
    """``--only 8`` runs the group holding Figure 8 (Figures 7-9) and nothing else."""
    proc = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "reproduce_linear.py"), "--quick", "--only",
         "8", "--fmu", str(fmu), "--out", str(tmp_path)],
        capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert sorted(p.name for p in tmp_path.glob("*.png")) == ["fig07-09_restitution_linear.png"]
    summary = json.loads((tmp_path / "linear_quick_only_7-9.json").read_text())
    assert list(summary["groups"]) == ["7-9"]
