"""Load-case tables (seasons/cases.py): TOML and CSV read alike, repetitions, and refusals naming
the file, the case, the field and the value."""

from __future__ import annotations

import math

import pytest

from iceimpact import Scene
from iceimpact.runspec import apply
from iceimpact.seasons import (
    PERTURBATION_M,
    SeasonError,
    load_cases,
    perturbation,
    perturbed_z0,
    season_runs,
)
from season_tables import CSV, TOML, write


# Parsing ----------------------------------------------------------------------------------------
def test_toml_and_csv_tables_are_the_same(tmp_path):
    toml = load_cases(write(tmp_path, TOML))
    table = load_cases(write(tmp_path, CSV, "cases.csv"), t_end=6.0, transient=1.0, dt=0.01)
    assert [c.name for c in toml.cases] == ["slow drift", "fast floe"]
    assert toml.cases[0].params == {"flow.u": 0.1, "ice.M": 1600.0}
    assert toml.cases[1].params == {"flow.u": 0.5, "impact.e": 0.8}
    assert [c.repetitions for c in toml.cases] == [3, 2]   # the top-level default for "fast"
    assert toml.base.drag_model == 2 and toml.hours == 400.0 and toml.n_runs == 5
    assert (toml.t_end, toml.transient, toml.dt) == (6.0, 1.0, 0.01)
    # CSV: no top-level default repetitions (1), drag.model given per case
    assert [c.repetitions for c in table.cases] == [3, 1]
    assert table.cases[0].params == {"drag.model": 2, "flow.u": 0.1, "ice.M": 1600.0}
    names, points, labels = season_runs(toml)
    assert names == ("drag.model", "flow.u", "ice.M", "impact.e", "ice.z0")
    assert labels == {"case": [0, 0, 0, 1, 1], "repetition": [0, 1, 2, 0, 1]}
    assert points[3][:4] == (2, 0.5, 1600.0, 0.8)  # ice.M from the base scene


def test_repetitions_move_the_ice_start_deterministically():
    z0 = Scene().ice_z0
    assert perturbed_z0(z0, 0) == z0
    moves = [z0 - perturbed_z0(z0, k) for k in range(4)]
    assert moves[1] == pytest.approx(PERTURBATION_M, rel=1e-2) and moves == sorted(moves)
    assert len({perturbed_z0(z0, k) for k in range(100)}) == 100
    # far from the structure the move is 64 units in the last place, so that it is not lost
    assert perturbation(-1000.0) == 64 * math.ulp(1000.0)
    assert perturbed_z0(-1000.0, 1) < -1000.0


@pytest.mark.parametrize("text, message", [
    ("t_end = 6.0\n[[case]]\nhours = 1.0\n", "case 1: name is missing"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\n", r"case 1 \('a'\): hours is missing"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = -1.0\n",
     r"case 1 \('a'\): hours = -1.0: expected a finite number in \[0, 8784\] \(hours per year"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = 9000\n", r"hours = 9000: expected"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = '5'\n", r"hours = '5': expected a finite"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = nan\n", r"hours = nan: expected"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = 1.0\nrepetitions = 0\n",
     r"repetitions = 0: expected an integer in \[1, 1000\]"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = 1.0\nrepetitions = 2.5\n",
     r"repetitions = 2.5: expected an integer"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = 1.0\nrepetitions = true\n",
     r"repetitions = True: expected an integer"),
    ("t_end = 6.0\n[[case]]\nname = ''\nhours = 1.0\n", "name = '': expected a non-empty"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = 1.0\n[[case]]\nname = 'a'\nhours = 2.0\n",
     r"case 2 \('a'\): name = 'a': another case has that name"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = 1.0\n'ice.mass' = 2.0\n",
     r"case 1 \('a'\): ice.mass: unknown parameter 'ice.mass' \(did you mean 'ice.M'"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = 1.0\n'flow.u' = 'fast'\n",
     r"case 1 \('a'\): flow.u = 'fast': expected a finite number"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = 1.0\n'impact.e' = 1.5\n",
     r"case 1 \('a'\): impact.e = 1.5 is not allowed: 0 <= e <= 1"),
    ("t_end = 6.0\n[defaults]\n'ice.M' = -3.0\n[[case]]\nname = 'a'\nhours = 1.0\n",
     r"\[defaults\]: ice.M = -3.0 is not allowed"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = 1.0\n'flow.u' = 0.1\nflow.u = 0.2\n",
     "flow.u is given twice|not valid TOML"),
    ("t_end = 6.0\nlife = 25\n[[case]]\nname = 'a'\nhours = 1.0\n",
     "unknown key 'life'; the top level holds t_end"),
    ("[[case]]\nname = 'a'\nhours = 1.0\n", "t_end is missing"),
    ("t_end = -1.0\n[[case]]\nname = 'a'\nhours = 1.0\n",
     r"t_end = -1.0: expected a finite number in \(0, inf\)"),
    ("t_end = 6.0\ntransient = 6.0\n[[case]]\nname = 'a'\nhours = 1.0\n",
     r"transient = 6.0: expected a number in \[0, t_end\)"),
    ("t_end = 6.0\ndt = 7.0\n[[case]]\nname = 'a'\nhours = 1.0\n", r"dt = 7.0: expected"),
    ("t_end = 1e9\ndt = 1e-3\n[[case]]\nname = 'a'\nhours = 1.0\n", "samples per run"),
    ("t_end = 6.0\n", "no case"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = 0.0\n", "hours add up to 0"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = 8000.0\n"
     "[[case]]\nname = 'b'\nhours = 800.0\n", "add up to 8800 h per year, more than the 8784 h"),
    ("t_end = 6.0\n[[case]]\nname = 'a'\nhours = 1.0\nrepetitions = 1000\n"
     "[[case]]\nname = 'b'\nhours = 1.0\nrepetitions = 1000\n",
     "2,000 runs .* more than the limit"),
    ("t_end = 6.0\n[[case]\n", "not valid TOML"),
    ("t_end = 6.0\nscene = 'missing.toml'\n[[case]]\nname = 'a'\nhours = 1.0\n",
     "scene = 'missing.toml': .* not found"),
])
def test_bad_toml_tables_are_refused_naming_file_case_field_and_value(tmp_path, text, message):
    path = write(tmp_path, text)
    with pytest.raises(SeasonError, match=message) as info:
        load_cases(path, max_runs=1500)
    assert str(path) in str(info.value)


@pytest.mark.parametrize("text, message", [
    ("name,hours\na,1\nb\n", "line 3: 1 fields, the header has 2"),
    ("name,flow.u\na,1\n", "the header has no 'hours' column"),
    ("name,hours,hours\na,1,2\n", "column 'hours' appears twice"),
    ("name,hours\na,many\n", r"line 2, case 1 \('a'\): hours = 'many': expected"),
    ("name,hours,flow.u\na,1,0.1\nb,1,fast\n", r"line 3, case 2 \('b'\): flow.u = 'fast'"),
    ("name,hours,repetitions\na,1,-2\n", "repetitions = '-2': expected an integer"),
    ("name,hours\n,1\n", "line 2, case 1: name = '': expected a non-empty"),
    ("# nothing\n", "empty"),
])
def test_bad_csv_tables_are_refused_naming_the_line(tmp_path, text, message):
    path = write(tmp_path, text, "cases.csv")
    with pytest.raises(SeasonError, match=message):
        load_cases(path, t_end=6.0)


@pytest.mark.parametrize("text", [
    "t_end = 6.0\n[[case]]\nname = 'a'\nhours = 1.0\n[[case]]\nname = 'two modes'\n"
    "hours = 1.0\n[case.structure]\nmodel = 3\nmodes = 2\n[case.structure.mode2]\nf = 11.0\n"
    "phi = 0.6\n",
    "t_end = 6.0\n[defaults]\n'structure.model' = 3\n'structure.modes' = 2\n"
    "'structure.mode2.f' = 11.0\n'structure.mode2.phi' = 0.6\n[[case]]\nname = 'a'\n"
    "hours = 1.0\n[[case]]\nname = 'two modes'\nhours = 1.0\n",
])
def test_a_case_of_the_modal_structure_is_a_case_like_any_other(tmp_path, text):
    """A season's loads are the DELs of k x, k_c x with the modal structure
    (Scene.contact_stiffness): its cases, from nested tables, defaults or CSV columns, load and
    run with their modes."""
    table = load_cases(write(tmp_path, text))
    assert table.n_runs == 2
    scene = apply(table.base, table.cases[-1].params)
    assert scene.modal and scene.structure_modes == 2 and scene.structure_mode2_phi == 0.6
    csv = write(tmp_path, "name,hours,structure.model,structure.mode1.f\na,1,3,2.0\n", "c.csv")
    (case,) = load_cases(csv, t_end=6.0).cases
    assert case.params == {"structure.model": 3, "structure.mode1.f": 2.0}
    # a bad mode is still refused before anything runs, naming the case
    bad = write(tmp_path, "name,hours,structure.model,structure.mode1.m\na,1,3,0\n", "d.csv")
    with pytest.raises(SeasonError, match=r"line 2, case 1 \('a'\): structure.mode1.m"):
        load_cases(bad, t_end=6.0)


def test_unreadable_files_are_refused(tmp_path):
    with pytest.raises(SeasonError, match="no such file"):
        load_cases(tmp_path / "none.toml")
    bad = tmp_path / "bad.toml"
    bad.write_bytes(b"t_end = 6.0\n# \xff\n")
    with pytest.raises(SeasonError, match="not UTF-8"):
        load_cases(bad)
    with pytest.raises(SeasonError, match="t_end is missing"):
        load_cases(write(tmp_path, "name,hours\na,1\n", "c.csv"))  # CSV: t_end from the caller
