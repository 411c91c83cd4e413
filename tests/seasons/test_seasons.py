"""The seasons' runs (seasons/__init__.py): resumable, equal to serial, through the command line,
and the layering of the packages."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from iceimpact import Scene, run
from iceimpact.seasons import (
    SeasonError,
    load_cases,
    perturbed_z0,
    run_season,
)
from iceimpact.studies.loads import WOHLER_EXPONENTS
from iceimpact.sweep import read_table
from season_tables import TOML, write


# The runs ---------------------------------------------------------------------------------------
def test_season_runs_resume_and_match_serial(tmp_path):
    table = load_cases(write(tmp_path, TOML))
    serial, summary = run_season(table, 25.0, workers=1, progress=False)
    out = tmp_path / "season"
    rows, summary2 = run_season(table, 25.0, out=out, workers=2, progress=False)
    strip = [{k: v for k, v in r.items() if k != "wall_s"} for r in rows]
    assert json.dumps(strip) == json.dumps([{k: v for k, v in r.items() if k != "wall_s"}
                                            for r in serial])  # nan-aware
    assert summary2["lifetime"] == summary["lifetime"]
    assert [r["case"] for r in rows] == [0, 0, 0, 1, 1]
    assert [r["ice.z0"] for r in rows[:3]] == [perturbed_z0(-0.01, k) for k in range(3)]
    # the saved table: one row per run; the summary is plain JSON with units
    assert len(read_table(f"{out}.csv")) == 5
    saved = json.loads(Path(f"{out}.json").read_text())
    assert saved["lifetime"]["del_1Hz_N"]["4"] == pytest.approx(
        summary["lifetime"]["del_1Hz_N"]["4"])
    assert saved["units"]["*_N"] == "N" and saved["settings"]["runs_table"] == "season.csv"
    # cut the table after two runs: the rerun runs the three missing ones only
    lines = Path(f"{out}.csv").read_text().splitlines(keepends=True)
    Path(f"{out}.csv").write_text("".join(lines[:3]))
    done: list[int] = []
    again, _ = run_season(table, 25.0, out=out, workers=1, progress=False,
                          on_rows=lambda b: done.extend(r["run"] for r in b))
    assert sorted(done) == [2, 3, 4] and [r["run"] for r in again] == list(range(5))
    # other hours and life: nothing runs, the summary follows
    table2 = load_cases(write(tmp_path, TOML.replace("hours = 100.0", "hours = 0.0")))
    done.clear()
    _, summary3 = run_season(table2, 10.0, out=out, workers=1, progress=False,
                             on_rows=lambda b: done.extend(r["run"] for r in b))
    assert done == [] and summary3["lifetime"]["ice_hours"] == 3000.0
    # other runs: refused like a different sweep
    table3 = load_cases(write(tmp_path, TOML.replace("repetitions = 3", "repetitions = 4")))
    with pytest.raises(SeasonError.__mro__[1], match="different sweep"):
        run_season(table3, 25.0, out=out, workers=1, progress=False)


#: The two-mode structure of Figure 2 (an 11 Hz second mode seen at 0.6) in a season: two
#: repetitions of one case and a second, faster case.
MODAL_TOML = """\
t_end = 6.0
transient = 1.0
dt = 0.01
repetitions = 2
[defaults]
"structure.model" = 3
"structure.modes" = 2
"structure.mode2.f" = 11.0
"structure.mode2.zeta" = 0.02
"structure.mode2.phi" = 0.6
[[case]]
name = "slow"
hours = 300.0
[[case]]
name = "fast"
hours = 100.0
repetitions = 1
"flow.u" = 0.5
"impact.e" = 0.8
"""


def test_a_season_of_the_modal_structure_gives_the_dels_of_k_c_x_by_hand(tmp_path):
    """The modal structure's season loads are the DELs of k_c x, k_c = 1 / sum(phi_k^2 /
    (m_k omega_k^2)): here from run()'s x of each repetition, times k_c worked out from the
    modes, cycles counted by the rainflow package, pooled and combined by hand."""
    rainflow = pytest.importorskip("rainflow")
    table = load_cases(write(tmp_path, MODAL_TOML))
    rows, summary = run_season(table, 25.0, workers=1, progress=False)
    assert [r["status"] for r in rows] == ["ok"] * 3
    modes = dict(structure_model=3, structure_modes=2, structure_mode2_f=11.0,
                 structure_mode2_zeta=0.02, structure_mode2_phi=0.6)
    # mode 1 is Figure 2's SDOF by default (1600 kg at 25 rad/s: k = 1e6 N/m)
    k_c = 1.0 / (1.0 / (1600.0 * 25.0 ** 2) + 0.36 / (1600.0 * (22.0 * math.pi) ** 2))
    cases = ((dict(), 2), (dict(flow_u=0.5, impact_e=0.8), 1))
    hours, life_dels = (300.0, 100.0), {m: [] for m in WOHLER_EXPONENTS}
    for i, (changes, reps) in enumerate(cases):
        sums = {m: 0.0 for m in WOHLER_EXPONENTS}
        window = 0.0
        for k in range(reps):
            result = run(Scene(**modes, **changes, ice_z0=perturbed_z0(-0.01, k)), 6.0, dt=0.01)
            late = result.t >= 1.0
            load = k_c * result.x[late]
            cycles = rainflow.count_cycles(load.tolist())
            for m in WOHLER_EXPONENTS:
                sums[m] += math.fsum(n * s ** m for s, n in cycles)
            window += result.t[-1] - 1.0
            row = rows[2 * i + k]
            assert row["kx_max_N"] == pytest.approx(load.max(), rel=1e-12)
            assert row["kx_min_N"] == pytest.approx(load.min(), rel=1e-12)
        case = summary["cases"][i]
        assert case["window_s"] == pytest.approx(window, rel=1e-15)
        for m in WOHLER_EXPONENTS:
            del_1hz = (sums[m] / window) ** (1.0 / m)
            assert del_1hz > 0.0
            assert case["del_1Hz_N"][f"{m}"] == pytest.approx(del_1hz, rel=1e-10), (i, m)
            assert case["del_1e7_N"][f"{m}"] == pytest.approx((sums[m] / 1e7) ** (1.0 / m),
                                                              rel=1e-10), (i, m)
            life_dels[m].append(del_1hz)
    for m in WOHLER_EXPONENTS:
        p = [h / sum(hours) for h in hours]
        life = sum(pi * d ** m for pi, d in zip(p, life_dels[m], strict=True)) ** (1.0 / m)
        assert summary["lifetime"]["del_1Hz_N"][f"{m}"] == pytest.approx(life, rel=1e-10), m


def test_a_table_begun_under_the_measures_earlier_name_resumes(tmp_path):
    table = load_cases(write(tmp_path, TOML))
    out = tmp_path / "season"
    run_season(table, 25.0, out=out, workers=1, progress=False)
    meta = Path(f"{out}.csv.meta.json")
    text = meta.read_text()
    assert "iceimpact.seasons.lifetime.season_measure" in text
    meta.write_text(text.replace("iceimpact.seasons.lifetime.season_measure",
                                 "iceimpact.studies.seasons.season_measure"))
    lines = Path(f"{out}.csv").read_text().splitlines(keepends=True)
    Path(f"{out}.csv").write_text("".join(lines[:3]))
    done: list[int] = []
    rows, _ = run_season(table, 25.0, out=out, workers=1, progress=False,
                         on_rows=lambda b: done.extend(r["run"] for r in b))
    assert sorted(done) == [2, 3, 4] and [r["run"] for r in rows] == list(range(5))


def test_cli_loads(tmp_path):
    cases = write(tmp_path, TOML)
    cmd = [sys.executable, "-m", "iceimpact.cli", "loads", str(cases), "--life", "25",
           "--out", str(tmp_path / "s"), "--workers", "1", "--quiet"]
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    assert "lifetime (25 years, 10000 ice hours): 1 Hz DEL m=3" in done.stdout
    assert json.loads((tmp_path / "s.json").read_text())["cases"][1]["name"] == "fast floe"
    bad = write(tmp_path, TOML.replace("hours = 100.0", "hours = -5"), "bad.toml")
    done = subprocess.run([*cmd[:4], str(bad), *cmd[5:]], capture_output=True, text=True,
                          check=False)
    assert done.returncode == 2 and "hours = -5: expected" in done.stderr
    assert "Traceback" not in done.stderr


def test_failed_runs_are_rows_and_the_command_exits_1(tmp_path):
    # a case whose runs stop (more impacts in a sample interval than solver.max_impacts allows)
    cases = write(tmp_path, TOML.replace("flow.u = 0.5", "flow.u = 1.0").replace(
        "impact.e = 0.8\n", 'impact.e = 0.8\n"ice.M" = 400.0\n"solver.max_impacts" = 1\n'))
    cmd = [sys.executable, "-m", "iceimpact.cli", "loads", str(cases), "--life", "25",
           "--out", str(tmp_path / "s"), "--workers", "1", "--quiet"]
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    assert done.returncode == 1, done.stderr
    assert "2 of 5 runs failed" in done.stderr and "SolverError" in done.stdout
    summary = json.loads((tmp_path / "s.json").read_text())
    assert not summary["lifetime"]["complete"]
    assert summary["lifetime"]["del_1Hz_N"]["4"] is None          # nan -> null
    assert len(summary["cases"][1]["failed"]) == 2
    assert summary["cases"][0]["del_1Hz_N"]["4"] > 0.0              # the other case is there
    again = subprocess.run([*cmd, "--allow-failures"], capture_output=True, text=True,
                           check=False)
    assert again.returncode == 0, again.stderr


def test_the_example_season_table_is_the_benchmarks_and_is_valid(tmp_path):
    import importlib.util

    root = Path(__file__).resolve().parents[2]
    spec = importlib.util.spec_from_file_location("season_benchmark",
                                                  root / "benchmarks" / "season.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    bench.write_cases(tmp_path / "cases.csv")
    shipped = root / "examples" / "season_cases.csv"
    assert (tmp_path / "cases.csv").read_text() == shipped.read_text()   # regenerate if not
    table = load_cases(shipped, t_end=600.0, transient=60.0)
    assert len(table.cases) == 50 and table.n_runs == 150
    assert table.hours == pytest.approx(1200.0) and table.base.drag_model == 1
    assert {c.params["drag.model"] for c in table.cases} == {2}


def test_the_analysis_never_loads_the_sweep_or_the_seasons():
    """Imports go seasons -> sweep -> studies: importing every module of iceimpact.studies
    loads neither the sweep engine nor the seasons package, and each seasons module imports
    first in a fresh interpreter."""
    code = ("import sys\nfor m in ('analysis', 'impacts', 'loads', 'outfiles'):\n"
            "    __import__('iceimpact.studies.' + m)\n"
            "print(sorted(m for m in sys.modules if m.startswith(('iceimpact.sweep', "
            "'iceimpact.seasons'))))\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "[]"
    for module in ("iceimpact.seasons.lifetime", "iceimpact.seasons.cases", "iceimpact.seasons"):
        proc = subprocess.run([sys.executable, "-c", f"import {module}"], capture_output=True,
                              text=True, timeout=120)
        assert proc.returncode == 0, (module, proc.stderr)
