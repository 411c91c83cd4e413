"""The modal structure (structure.model = 3) through the ``iceimpact`` command: ``--set
structure.mode2.f=11`` and scene files with ``[structure.mode2]`` tables give the run of the same
scene, a sweep varies a mode's parameters as the API does, and a bad mode value is an error
naming it."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from cli_helpers import rows_of, usage_error
from iceimpact import Scene, run
from iceimpact.cli import main
from iceimpact.scene import load_scene
from iceimpact.studies.analysis import summarize
from iceimpact.sweep import read_table, sweep

FAST = ["--t-end", "4", "--dt", "0.01"]
#: Two modes at the contact point (FMI names).
TWO_MODES = {"structure.model": 3, "structure.modes": 2, "structure.mode2.f": 11.0,
             "structure.mode2.zeta": 0.02, "structure.mode2.phi": 0.6, "drag.model": 2,
             "ice.M": 1200.0, "flow.u": 0.3, "impact.e": 0.7}
SCENE_TEXT = """\
"impact.e" = 0.7
[structure]
model = 3
modes = 2
[structure.mode2]
f = 11.0
zeta = 0.02
phi = 0.6
[drag]
model = 2
[ice]
M = 1200.0
[flow]
u = 0.3
"""


@pytest.fixture
def modal_file(tmp_path: Path) -> Path:
    path = tmp_path / "modal.toml"
    path.write_text(SCENE_TEXT)
    return path


def test_a_scene_file_takes_mode_tables(modal_file, tmp_path):
    assert load_scene(modal_file) == Scene.from_fmi(TWO_MODES)
    dotted = tmp_path / "dotted.toml"  # the same by dotted keys, and inline tables
    dotted.write_text('"structure.model" = 3\n"structure.modes" = 2\n'
                      'structure.mode2 = { f = 11.0, zeta = 0.02, phi = 0.6 }\n'
                      '"drag.model" = 2\n"ice.M" = 1200.0\n"flow.u" = 0.3\n"impact.e" = 0.7\n')
    assert load_scene(dotted) == Scene.from_fmi(TWO_MODES)


def test_simulate_by_set_and_by_scene_file_is_the_run(capsys, modal_file, tmp_path):
    sets = [f"--set={name}={value}" for name, value in TWO_MODES.items()]
    by_set, by_file = tmp_path / "set.csv", tmp_path / "file.csv"
    assert main(["simulate", *sets, *FAST, "--out", str(by_set)]) == 0
    assert main(["simulate", str(modal_file), *FAST, "--out", str(by_file)]) == 0
    text = capsys.readouterr().out
    assert by_set.read_bytes() == by_file.read_bytes()
    result = run(Scene.from_fmi(TWO_MODES), 4.0, dt=0.01)
    assert len(result.impacts) > 10
    assert f"{len(result.impacts)} impacts" in text
    samples = rows_of(by_set)
    assert len(samples) == 1 + result.t.size
    assert [float(row[1]) for row in samples[1:]] == result.x.tolist()
    # each mode's coordinate and velocity, by the FMU's names, after the common columns
    assert samples[0][-4:] == ["structure.mode1.q", "structure.mode1.v", "structure.mode2.q",
                               "structure.mode2.v"]
    assert [float(row[-2]) for row in samples[1:]] == result.modes_q[:, 1].tolist()
    assert [float(row[-1]) for row in samples[1:]] == result.modes_v[:, 1].tolist()
    # the k x loads are those of k_c x, the contact point's static stiffness worked out from
    # the modes (mode 1 Figure 2's k = 1e6 N/m, mode 2 1600 kg at 11 Hz seen at 0.6)
    k_c = 1.0 / (1.0 / 1.0e6 + 0.36 / (1600.0 * (22.0 * math.pi) ** 2))
    summary = summarize(result)
    assert summary["kx_max_N"] == pytest.approx(k_c * result.x.max(), rel=1e-14)
    assert summary["contact_force_max_N"] > 0.0
    printed = next(line for line in text.splitlines() if line.split()[:1] == ["kx_max_N"])
    assert float(printed.split()[1]) == pytest.approx(summary["kx_max_N"], rel=1e-5)  # %.6g


@pytest.mark.parametrize(("setting", "words"), [
    ("structure.mode1.m=-1", "structure.mode1.m = -1.0 is not allowed: > 0"),
    ("structure.modes=6", "structure.modes = 6 is not allowed: 1 <= modes <= 5"),
    ("structure.mode1.phi=0", "structure.mode1.phi = 0.0 is not allowed: not 0 for at least"),
    # the known names list the modes' parameters as one entry
    ("structure.mode6.f=3", "unknown parameter 'structure.mode6.f' (did you mean "
     "'structure.mode5.f'"),
    ("structure.mode6.f=3", "structure.modes, structure.mode<k>.{f, zeta, m, phi, q0, v0} "
     "(k = 1 to 5), structure.load_order, flow.u"),
])
def test_a_bad_mode_value_is_an_error_naming_it(capsys, setting, words):
    assert words in usage_error(capsys, ["simulate", "--set", "structure.model=3", "--set",
                                         setting, *FAST])


def test_a_bad_mode_value_in_a_scene_file_is_an_error_naming_it(capsys, tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(SCENE_TEXT.replace("zeta = 0.02", "zeta = -0.5"))
    err = usage_error(capsys, ["simulate", str(path), *FAST])
    assert "structure.mode2.zeta = -0.5 is not allowed: >= 0" in err


def test_sweep_varies_mode_parameters_as_the_api(capsys, modal_file, tmp_path):
    out = tmp_path / "sweep.csv"
    code = main(["sweep", str(modal_file), "--vary", "structure.mode2.f=8,14",
                 "--vary", "structure.mode2.load=0,500", *FAST, "--out", str(out),
                 "--workers", "1", "--quiet"])
    assert code == 0
    table = read_table(out)
    api = sweep(Scene.from_fmi(TWO_MODES), {"structure.mode2.f": [8.0, 14.0],
                                            "structure.mode2.load": [0.0, 500.0]},
                t_end=4.0, dt=0.01, workers=1, progress=False)
    assert [r["status"] for r in table] == ["ok"] * 4
    for got, want in zip(table, api, strict=True):
        for key in ("structure.mode2.f", "structure.mode2.load", "n_impacts", "x_peak_m",
                    "omega_n_rad_s"):
            assert got[key] == want[key], key
    # omega_n is the highest mode seen at the contact point, the loads change the motion
    assert [r["omega_n_rad_s"] for r in table] == pytest.approx(
        [2 * math.pi * 8.0] * 2 + [2 * math.pi * 14.0] * 2)
    assert table[0]["x_mean_m"] != table[1]["x_mean_m"]
    assert "4 runs (4 ok, 0 errors)" in capsys.readouterr().out
