"""OpenFAST text output (``iceimpact simulate --format openfast``): the file is read back by
openfast-io and by pCrunch as they read OpenFAST's, and every channel equals the run's within
the printed precision (10 significant digits)."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from iceimpact import Scene, run
from iceimpact.cli import SAMPLE_COLUMNS, main
from iceimpact.contract import BY_NAME
from iceimpact.studies.outfiles import (
    DIGITS,
    OUT_CHANNELS,
    TIME_CHANNEL,
    header_lines,
    read_out,
    run_channels,
    write_openfast,
    write_out,
)

T_END, DT = 4.0, 0.01
ARGS = ["--t-end", str(T_END), "--dt", str(DT)]
#: The printed precision: half a unit of the last of DIGITS + 1 significant digits.
RTOL = 0.5 * 10.0 ** -DIGITS * (1 + 1e-6)


@pytest.fixture(scope="module")
def reference():
    """The channels of the run the CLI makes with ARGS (the Figure 2 scene)."""
    return run_channels(run(Scene(), T_END, dt=DT))


@pytest.fixture(scope="module")
def out_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("out") / "fig2.out"
    assert main(["simulate", *ARGS, "--out", str(path)]) == 0  # .out: openfast by default
    return path


def assert_channels_equal(names, units, data, reference) -> None:
    expected_names = [TIME_CHANNEL, *OUT_CHANNELS]
    assert list(names) == expected_names
    assert list(units) == ["s", *(BY_NAME[n].unit or "-" for n in OUT_CHANNELS)]
    assert data.shape == (reference[TIME_CHANNEL].size, len(expected_names))
    for i, name in enumerate(expected_names):
        want = reference[name]
        assert np.all(np.abs(data[:, i] - want) <= RTOL * np.abs(want)), name


def test_openfast_io_reads_every_channel(out_file: Path, reference) -> None:
    fast_output = pytest.importorskip("openfast_io.FAST_output_reader")
    out = fast_output.FASTOutputFile(str(out_file))
    assert out.info["description"] == (
        "Description from the IceImpact input: Figure 2 scene, t_end 4 s, dt 0.01 s")
    assert_channels_equal(out.info["attribute_names"], out.info["attribute_units"], out.data,
                          reference)
    # its DataFrame names the columns with their units, as for OpenFAST's files
    assert list(out.toDataFrame().columns)[:2] == ["Time_[s]", "structure.x_[m]"]


def test_pcrunch_reads_every_channel(out_file: Path, reference) -> None:
    pcrunch = pytest.importorskip("pCrunch")
    out = pcrunch.OpenFASTAscii(str(out_file))
    assert_channels_equal(out.channels, out.units, out.data, reference)
    assert "IceImpact" in out.description


def test_own_reader_and_the_layout(out_file: Path, reference) -> None:
    lines = out_file.read_text(encoding="ascii").splitlines()
    assert lines[0] == "" and lines[3] == "" and lines[5] == ""
    assert lines[1].startswith("Predictions were generated on ")
    assert lines[6].split("\t")[0] == TIME_CHANNEL and lines[7].startswith("(s)\t")
    # the readers take the first line starting with "Time" as the names: only line 7 does
    assert [i for i, line in enumerate(lines) if line.startswith("Time")] == [6]
    assert all(line.count("\t") == len(OUT_CHANNELS) for line in lines[6:])
    channels, units, description = read_out(out_file)
    assert description.startswith("Figure 2 scene")
    assert units["contact.impulse"] == "N.s" and units["contact.count"] == "-"
    data = np.column_stack(list(channels.values()))
    assert_channels_equal(channels, units.values(), data, reference)


def test_channels_agree_with_the_run_and_the_csv(tmp_path: Path, reference) -> None:
    """The .out holds the CSV's columns (same values) plus the forces and the impact count."""
    path = tmp_path / "s.csv"
    assert main(["simulate", *ARGS, "--out", str(path)]) == 0
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    columns = dict(zip(rows[0], np.array(rows[1:], dtype=float).T, strict=True))
    for name, _ in SAMPLE_COLUMNS:
        key = TIME_CHANNEL if name == "time" else name
        np.testing.assert_array_equal(columns[name], reference[key])
    result = run(Scene(), T_END, dt=DT)
    np.testing.assert_array_equal(reference["structure.force"], Scene().structure_k * result.x)
    assert reference["contact.count"][-1] == len(result.impacts)
    assert np.all(np.diff(reference["contact.count"]) >= 0)
    np.testing.assert_allclose(reference["contact.force"][1:] * DT, result.impulse[1:],
                               rtol=1e-9)


def test_format_option_beats_the_suffix(tmp_path: Path) -> None:
    as_out = tmp_path / "a.csv"
    assert main(["simulate", *ARGS, "--format", "openfast", "--out", str(as_out)]) == 0
    assert as_out.read_text().splitlines()[6].startswith("Time\t")
    as_csv = tmp_path / "b.out"
    assert main(["simulate", *ARGS, "--format", "csv", "--out", str(as_csv)]) == 0
    assert as_csv.read_text().splitlines()[0].startswith("time,structure.x,")


@pytest.mark.parametrize("argv,words", [
    (["--format", "xlsx", "--out", "x.out"],
     ["argument --format: invalid choice: 'xlsx'", "'csv', 'openfast'"]),
    (["--format", "openfast"], ["--format openfast", "--out"]),
])
def test_format_errors(capsys, argv: list[str], words: list[str]) -> None:
    with pytest.raises(SystemExit) as info:
        main(["simulate", *ARGS, *argv])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    for word in words:
        assert word in err


def test_header_is_ascii_on_one_line_each(tmp_path: Path) -> None:
    result = run(Scene(), 0.5, dt=0.1)
    path = write_openfast(tmp_path / "r.out", result,
                          description="Wöhler\tcase µ\nsecond line", generated=0.0)
    lines = path.read_bytes().decode("ascii").splitlines()
    assert lines[4] == "Description from the IceImpact input: Wohler case \\u03bc second line"
    assert len(lines) == 8 + result.t.size


def test_write_out_refuses_what_readers_cannot_read(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="different lengths"):
        write_out(tmp_path / "a.out", {"Time": [0.0, 1.0], "structure.x": [0.0]})
    with pytest.raises(ValueError, match="without whitespace"):
        header_lines(["Time", "a b"], ["s", "m"])
    with pytest.raises(ValueError, match="first channel"):
        header_lines(["x", "Time"], ["m", "s"])
    with pytest.raises(ValueError, match="units"):
        header_lines(["Time"], ["s", "m"])


CASES = """\
t_end = 4.0
transient = 1.0
dt = 0.01
[[case]]
name = "slow drift"
hours = 300.0
repetitions = 2
"flow.u" = 0.1
[[case]]
name = "fast floe / thick"
hours = 100.0
"flow.u" = 0.5
"""


def test_each_load_case_run_as_an_out_file(tmp_path: Path) -> None:
    """Every run of a load-case table as a .out (the runs of ``iceimpact loads``, repetitions
    included): read back by openfast-io, its k x gives the DEL of that run's row in PREFIX.csv
    within the printed precision."""
    fast_output = pytest.importorskip("openfast_io.FAST_output_reader")
    from iceimpact.seasons import load_cases, run_season, series_row, write_case_series
    from iceimpact.studies.outfiles import case_file_name

    path = tmp_path / "cases.toml"
    path.write_text(CASES)
    table = load_cases(path)
    paths = write_case_series(table, tmp_path / "series", generated=0.0)
    assert [p.name for p in paths] == ["case00_slow-drift_rep0.out", "case00_slow-drift_rep1.out",
                                       "case01_fast-floe-thick_rep0.out"]
    assert case_file_name(3, "µ-ice", 2) == "case03_u03bc-ice_rep2.out"
    rows, _ = run_season(table, 25.0, out=None, workers=1, progress=False)
    assert len(rows) == len(paths)
    for row, out_path in zip(rows, paths, strict=True):
        out = fast_output.FASTOutputFile(str(out_path))
        names = out.info["attribute_names"]
        assert repr(table.cases[row["case"]].name) in out.info["description"]
        t, kx = out.data[:, 0], out.data[:, names.index("structure.force")]
        again = series_row(t, kx, 1.0, transient=table.transient)  # k = 1: the force itself
        for m in (3, 4, 10):
            key = f"del_m{m}_1Hz_N"
            assert again[key] == pytest.approx(row[key], rel=1e-8), (out_path.name, key)
        assert again["kx_max_N"] == pytest.approx(row["kx_max_N"], rel=RTOL)


def test_the_loads_command_writes_each_runs_out_file(tmp_path: Path) -> None:
    from iceimpact.cli import main

    path = tmp_path / "cases.toml"
    path.write_text(CASES)
    status = main(["loads", str(path), "--life", "25", "--out", str(tmp_path / "season"),
                   "--workers", "1", "--quiet", "--series", str(tmp_path / "series")])
    assert status == 0
    assert sorted(p.name for p in (tmp_path / "series").iterdir()) == [
        "case00_slow-drift_rep0.out", "case00_slow-drift_rep1.out",
        "case01_fast-floe-thick_rep0.out"]


def test_the_modal_structures_force_channel_is_k_c_x(tmp_path: Path) -> None:
    """structure.force of the modal structure is k_c x, k_c = 1 / sum(phi_k^2 / (m_k omega_k^2))
    (worked out here from the modes), as the FMU reports it (its structure.k is ignored): in the
    channels, in the written file to its printed precision and in the loads of the run."""
    from iceimpact.studies.loads import run_loads

    scene = Scene(structure_model=3, structure_modes=2, structure_mode2_f=11.0,
                  structure_mode2_phi=0.6, structure_k=5.0e5)
    k_c = 1.0 / sum(phi * phi / (m * (2.0 * np.pi * f) ** 2)
                    for f, _, m, phi, _, _ in scene.mode_table)
    result = run(scene, T_END, dt=DT)
    channels = run_channels(result)
    assert result.x.any()
    np.testing.assert_allclose(channels["structure.force"], k_c * result.x, rtol=1e-14,
                               atol=0.0)
    np.testing.assert_array_equal(channels["structure.x"], result.x)
    write_openfast(tmp_path / "modal.out", result)
    written = read_out(tmp_path / "modal.out")[0]["structure.force"]
    want = channels["structure.force"]
    assert np.all(np.abs(written - want) <= RTOL * np.abs(want))
    loads = run_loads(result)
    assert loads.kx.max == pytest.approx(k_c * result.x.max(), rel=1e-14)
    assert loads.kx.min == pytest.approx(k_c * result.x.min(), rel=1e-14)
    assert loads.contact.max > 0.0
