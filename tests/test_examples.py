"""The example scripts run end to end: the reproduction scripts (examples/reproduce_*.py) in
their quick mode, the demo (examples/demo.py) over 20 s.

Each script is run as a user would, in a subprocess, with ``--quick`` (every case shortened to a
few seconds, still through IceImpact.fmu with FMPy, both solvers): it must exit with status 0,
print its tables and write one PNG per figure group and its JSON summary. The FMU is the one in
``dist/`` (built by ``build_fmu.py`` if missing).
"""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
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


def _read_csv(path: Path) -> dict[str, np.ndarray]:
    """The columns of a CSV written by examples/demo.py, by output name."""
    with path.open() as f:
        names = f.readline().strip().split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {name: data[:, i] for i, name in enumerate(names)}


def test_demo_csv_is_decimated_and_keeps_the_impulses(fmu: Path, tmp_path: Path) -> None:
    """``examples/demo.py`` writes every output every 10 ms by default: a CSV of a reasonable
    size whose impulses are the sums of the 1 ms steps' impulses (``--full-rate``), and whose
    cumulative and state columns are the full-rate values at the same times."""
    stop = 20.0
    tables = {}
    for mode, extra in (("default", []), ("full", ["--full-rate"])):
        out = tmp_path / mode
        proc = subprocess.run(
            [sys.executable, str(ROOT / "examples" / "demo.py"), "--fmu", str(fmu),
             "--stop-time", str(stop), "--out", str(out)] + extra,
            capture_output=True, text=True, cwd=ROOT, timeout=300)
        assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
        assert (out / "demo.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        tables[mode] = (_read_csv(out / "demo.csv"), (out / "demo.csv").stat().st_size)
    (dec, dec_size), (full, full_size) = tables["default"], tables["full"]

    assert len(full["time"]) == round(stop / 1e-3) + 1
    assert len(dec["time"]) == round(stop / 1e-2) + 1
    np.testing.assert_allclose(np.diff(dec["time"]), 1e-2, rtol=1e-9)
    # reasonable: a tenth of the full-rate file, under 10 MB for the default 400 s
    assert dec_size < 0.15 * full_size
    assert dec_size * 400.0 / stop < 10e6
    # the sizes docs/getting-started/demo.md quotes for 400 s ("about N MB"), to 15 %
    page = (ROOT / "docs" / "getting-started" / "demo.md").read_text()
    quoted = [float(n) for n in re.findall(r"about\s+(\d+(?:\.\d+)?)\s+MB", page)]
    assert len(quoted) == 2, quoted
    for size, mb in zip((dec_size, full_size), quoted, strict=True):
        assert abs(size * 400.0 / stop / 1e6 - mb) <= 0.15 * mb, (size * 400.0 / stop, mb)

    # impulses: every 10 ms row holds the sum over its ten 1 ms steps
    assert full["contact.count"][-1] >= 2  # the first impacts happen within 20 s
    assert full["contact.impulse"].sum() > 0.0
    np.testing.assert_allclose(dec["contact.impulse"].sum(), full["contact.impulse"].sum(),
                               rtol=1e-9)
    np.testing.assert_allclose(np.cumsum(dec["contact.impulse"]),
                               np.cumsum(full["contact.impulse"])[::10], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(dec["contact.force"][1:], dec["contact.impulse"][1:] / 1e-2,
                               rtol=1e-9, atol=1e-9)
    # cumulative and state outputs: the full-rate values at the row's time
    for name in ("contact.count", "contact.t_last", "structure.x", "ice.z", "contact.active"):
        np.testing.assert_array_equal(dec[name], full[name][::10], err_msg=name)


def test_ice_on_tower_quick_mode(fmu: Path, tmp_path: Path) -> None:
    """examples/system/ice_on_tower.py: a 3-mode tower (ModalStructure.fmu) struck through
    IceImpact.fmu in external-structure mode, and two SDOF idealisations with the built-in
    structure."""
    if not (fmu.parent / "ModalStructure.fmu").exists():
        subprocess.run([sys.executable, str(ROOT / "build_fmu.py"), "--fmu", "ModalStructure"],
                       check=True, cwd=ROOT)
    proc = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "system" / "ice_on_tower.py"), "--quick",
         "--fmus", str(fmu.parent), "--out", str(tmp_path)],
        capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert (tmp_path / "ice_on_tower.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    summary = json.loads((tmp_path / "ice_on_tower.json").read_text())
    runs = summary["runs"]
    tower, local, first = (runs["3-mode tower"], runs["SDOF, impulse mass"],
                           runs["SDOF, first mode"])
    assert min(r["impacts"] for r in runs.values()) >= 1
    # the same free flight to the structure at rest: the first impact in the same step
    assert tower["first impact (s)"] == local["first impact (s)"] == first["first impact (s)"]
    # the tower at rest opposes its impulse mass to the first impact: the same impulse as the
    # SDOF of that mass (eq. 16-17), unlike the SDOF of the first mode alone
    assert tower["1st step impulse (N.s)"] == pytest.approx(local["1st step impulse (N.s)"],
                                                             rel=1e-9)
    assert abs(first["1st step impulse (N.s)"] / tower["1st step impulse (N.s)"] - 1.0) > 0.1


def test_morison_effect_script_runs(tmp_path: Path) -> None:
    """``examples/morison_effect.py`` over 5 s: a table row per scene and variant, the PNG, and
    the wet natural frequency sqrt(k / (m + rho Ca V)) where the added mass is on."""
    proc = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "morison_effect.py"), "--t-end", "5",
         "--out", str(tmp_path)],
        capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    rows = [line for line in proc.stdout.splitlines() if line.startswith("| Figure")]
    assert len(rows) == 8
    wet = f"{(1.0e6 / (1600.0 + 999.0 * math.pi / 4)) ** 0.5:.2f}"
    assert [row.split("|")[3].strip() for row in rows] == ["25.00", wet, "25.00", wet] * 2
    assert (tmp_path / "morison_effect.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
