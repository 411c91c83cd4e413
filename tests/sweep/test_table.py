"""Sweep engine: grid specs, rows equal to direct runs, parallel = serial, resume, errors."""

from __future__ import annotations

import csv
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from iceimpact import Scene, run
from iceimpact.studies.analysis import SUMMARY_FIELDS, summarize
from iceimpact.sweep import (
    SweepError,
    check_grid_size,
    grid_points,
    meta_path,
    normalize_grid,
    parse_set,
    parse_values,
    parse_vary,
    read_table,
    sweep,
)

T_END, TRANSIENT, DT = 4.0, 1.0, 1e-2   # s: a run costs ~10 ms
GRID = {"flow.u": [0.1, 0.3], "impact.e": [0.5, 0.8, 1.0]}


def same(a: dict, b: dict, skip=("wall_s",)) -> bool:
    """Rows equal value for value (nan == nan), ignoring the wall time."""
    if a.keys() != b.keys():
        return False
    for key in a:
        if key in skip:
            continue
        x, y = a[key], b[key]
        if isinstance(x, float) and isinstance(y, float) and math.isnan(x) and math.isnan(y):
            continue
        if x != y:
            return False
    return True


def assert_same_rows(rows_a: list[dict], rows_b: list[dict]) -> None:
    assert len(rows_a) == len(rows_b)
    for a, b in zip(rows_a, rows_b, strict=True):
        assert same(a, b), (a, b)


@pytest.fixture(scope="module")
def serial_rows() -> list[dict]:
    return sweep(None, GRID, t_end=T_END, transient=TRANSIENT, dt=DT, workers=1, progress=False)


# Grid specifications ---------------------------------------------------------------------------
def test_linspace_includes_both_ends():
    assert parse_values("0:1:5") == [0.0, 0.25, 0.5, 0.75, 1.0]
    assert parse_values("0.01:2:50")[-1] == 2.0 and len(parse_values("0.01:2:50")) == 50
    assert parse_values("3:7:1") == [3.0]


def test_log_spacing_and_lists():
    values = parse_values("log:0.01:1:3")
    assert values[0] == 0.01 and values[-1] == 1.0
    assert values[1] == pytest.approx(0.1, rel=1e-12)
    assert parse_values("LOG:-1:-100:3")[1] == pytest.approx(-10.0)
    assert parse_values("0.5, 1,2e-1") == [0.5, 1.0, 0.2]
    assert parse_values("7") == [7.0]


def test_parse_vary_names_and_integer_parameters():
    assert parse_vary("flow.u=0:2:3") == ("flow.u", [0.0, 1.0, 2.0])
    name, values = parse_vary("drag.model=1,2")
    assert name == "drag.model" and values == [1, 2]
    assert all(isinstance(v, int) for v in values)
    assert parse_vary("drag.model=1.5")[1] == [1.5]  # not an integer: an error row later
    assert parse_set("ice.A=2") == ("ice.A", 2.0)


@pytest.mark.parametrize("spec,words", [
    ("ice.mass=1,2", ["unknown parameter 'ice.mass'", "ice.M", "flow.u"]),
    ("flow.u", ["NAME=START:STOP:COUNT"]),
    ("=1,2", ["NAME=START:STOP:COUNT"]),
    ("flow.u=", ["no values"]),
    ("flow.u=0:1", ["START:STOP:COUNT"]),
    ("flow.u=0:1:2:3", ["START:STOP:COUNT"]),
    ("flow.u=a:1:3", ["'a' is not a number"]),
    ("flow.u=0:1:2.5", ["COUNT '2.5' is not an integer"]),
    ("flow.u=0:1:0", ["COUNT must be >= 1"]),
    ("flow.u=log:0:1:3", ["nonzero with the same sign"]),
    ("flow.u=log:-1:1:3", ["nonzero with the same sign"]),
    ("flow.u=log:1:3", ["log:START:STOP:COUNT"]),
    ("flow.u=1,,2", ["empty item"]),
    ("flow.u=1,nan", ["not finite"]),
])
def test_malformed_vary_is_an_error_naming_the_argument(spec, words):
    with pytest.raises(SweepError) as err:
        parse_vary(spec)
    message = str(err.value)
    assert f"--vary {spec!r}" in message
    for word in words:
        assert word in message


def test_grid_order_first_parameter_slowest():
    grid = normalize_grid({"flow.u": np.array([1.0, 2.0]), "impact.e": (0.5, 1)})
    assert grid == {"flow.u": [1.0, 2.0], "impact.e": [0.5, 1.0]}
    assert grid_points(grid) == [(1.0, 0.5), (1.0, 1.0), (2.0, 0.5), (2.0, 1.0)]


@pytest.mark.parametrize("grid,words", [
    ({}, "empty"), ({"ice.mass": [1.0]}, "unknown parameter"), ({"ice.M": []}, "no values"),
    ({"ice.M": "100"}, "sequence"), ({"ice.M": ["a"]}, "not a number"),
    ({"ice.M": [1.0, float("nan")]}, "not finite"), ({"impact.e": [True]}, "not a number"),
])
def test_bad_grids_are_rejected_before_running(grid, words):
    with pytest.raises(SweepError, match=words):
        sweep(None, grid, t_end=1.0, progress=False)


@pytest.mark.parametrize("kwargs,words", [
    ({"t_end": -1.0}, "t_end"), ({"dt": 0.0}, "dt"), ({"transient": 4.0}, "transient"),
    ({"workers": 0}, "workers"), ({"chunksize": 0}, "chunksize"), ({"fmt": "xlsx"}, "format"),
])
def test_bad_settings_are_rejected(tmp_path, kwargs, words):
    settings = {"t_end": T_END, "dt": DT, "out": tmp_path / "s.csv", **kwargs}
    with pytest.raises(SweepError, match=words):
        sweep(None, {"flow.u": [0.1]}, progress=False, **settings)


@pytest.mark.parametrize("kwargs,words", [
    ({"t_end": 10**400}, "t_end = 1000.* expected a finite number > 0"),
    ({"dt": -(10**400)}, "dt = -1000.* expected a number in"), ({"t_end": True}, "t_end = True"),
    ({"transient": np.bool_(False)}, "transient = np.False_: expected a number"),
])
def test_settings_that_are_no_finite_number_are_a_sweep_error(kwargs, words):
    """t_end = 10**400 raised a bare OverflowError."""
    with pytest.raises(SweepError, match=words):
        sweep(None, {"flow.u": [0.1]}, progress=False, **{"t_end": T_END, "dt": DT, **kwargs})


def test_numpy_settings_run_like_python_ones():
    rows = sweep(None, {"flow.u": [0.1]}, t_end=np.float32(T_END), dt=np.float64(DT),
                 transient=np.int64(0), workers=1, progress=False)
    want = sweep(None, {"flow.u": [0.1]}, t_end=float(np.float32(T_END)), dt=DT, transient=0.0,
                 workers=1, progress=False)
    assert_same_rows(rows, want)


# Rows ------------------------------------------------------------------------------------------
def test_rows_equal_direct_runs(serial_rows):
    assert len(serial_rows) == 6
    columns = ["run", "flow.u", "impact.e", "status", "wall_s", *SUMMARY_FIELDS]
    for index, ((u, e), row) in enumerate(zip(grid_points(GRID), serial_rows, strict=True)):
        assert list(row) == columns
        assert (row["run"], row["flow.u"], row["impact.e"], row["status"]) == (index, u, e, "ok")
        assert row["wall_s"] > 0.0
        expected = summarize(run(Scene(flow_u=u, impact_e=e), T_END, dt=DT), TRANSIENT)
        assert same({k: row[k] for k in expected}, expected)


def test_base_scene_is_kept_for_the_other_parameters():
    base = Scene(drag_model=2, ice_M=800.0)
    (row,) = sweep(base, {"flow.u": [0.2]}, t_end=T_END, dt=DT, workers=1, progress=False)
    expected = summarize(run(base.replace(flow_u=0.2), T_END, dt=DT), 0.0)
    assert same({k: row[k] for k in expected}, expected)


def test_parallel_equals_serial(serial_rows):
    rows = sweep(None, GRID, t_end=T_END, transient=TRANSIENT, dt=DT, workers=2, chunksize=1,
                 progress=False)
    assert_same_rows(rows, serial_rows)


def test_invalid_combination_is_an_error_row_not_a_crash():
    rows = sweep(None, {"impact.e": [0.5, 1.5], "drag.model": [2, 3]}, t_end=T_END, dt=DT,
                 workers=1, progress=False)
    assert [r["status"] == "ok" for r in rows] == [True, False, False, False]
    assert rows[1]["status"].startswith("drag.model = 3 is not allowed: 1 or 2")
    assert rows[2]["status"].startswith("impact.e = 1.5 is not allowed")
    for row in rows[1:]:
        assert all(math.isnan(row[k]) for k in SUMMARY_FIELDS)


def square_measure(result, transient):
    """A custom measure (module level, so that worker processes can import it)."""
    return {"x_end_m": float(result.x[-1]), "transient_s": transient}


def test_custom_measure_sets_the_columns():
    rows = sweep(None, {"flow.u": [0.1, 0.2]}, t_end=T_END, transient=0.5, dt=DT, workers=2,
                 progress=False, measure=square_measure)
    assert list(rows[0]) == ["run", "flow.u", "status", "wall_s", "x_end_m", "transient_s"]
    assert rows[1]["x_end_m"] == float(run(Scene(flow_u=0.2), T_END, dt=DT).x[-1])


# Output and resume -----------------------------------------------------------------------------
def read_csv(path):
    with open(path, newline="") as fh:
        return list(csv.reader(fh))


def test_csv_round_trips_exactly(tmp_path, serial_rows):
    out = tmp_path / "sweep.csv"
    rows = sweep(None, GRID, t_end=T_END, transient=TRANSIENT, dt=DT, out=out, workers=1,
                 progress=False)
    assert_same_rows(rows, serial_rows)
    assert_same_rows(read_table(out), rows)
    table = read_csv(out)
    assert table[0][:5] == ["run", "flow.u", "impact.e", "status", "wall_s"]
    assert [r[0] for r in table[1:]] == [str(i) for i in range(6)]
    meta = json.loads(meta_path(out).read_text())
    assert meta["n_runs"] == 6 and meta["settings"]["t_end"] == T_END
    assert meta["settings"]["grid"] == [["flow.u", [0.1, 0.3]], ["impact.e", [0.5, 0.8, 1.0]]]


def test_resume_after_lost_rows_and_a_cut_line(tmp_path, serial_rows):
    out = tmp_path / "sweep.csv"
    sweep(None, GRID, t_end=T_END, transient=TRANSIENT, dt=DT, out=out, workers=1,
          progress=False)
    lines = out.read_text().splitlines(keepends=True)
    # keep the header, runs 0, 2, 3 and half of run 4's line (a write cut by a kill)
    out.write_text(lines[0] + lines[1] + lines[3] + lines[4] + lines[5][:40])
    redone = []
    rows = sweep(None, GRID, t_end=T_END, transient=TRANSIENT, dt=DT, out=out, workers=2,
                 progress=False, on_rows=lambda batch: redone.extend(r["run"] for r in batch))
    assert sorted(redone) == [1, 4, 5]
    assert_same_rows(rows, serial_rows)
    assert_same_rows(read_table(out), serial_rows)
    assert len(read_csv(out)) == 7  # header + 6 runs, no duplicates


def test_resume_after_an_interruption(tmp_path, serial_rows):
    out = tmp_path / "sweep.csv"

    def interrupt_after_two(batch):
        if sum(1 for _ in read_csv(out)) - 1 >= 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        sweep(None, GRID, t_end=T_END, transient=TRANSIENT, dt=DT, out=out, workers=1,
              chunksize=1, progress=False, on_rows=interrupt_after_two)
    assert len(read_table(out)) == 2  # rows are on disk as soon as their runs finish
    redone = []
    rows = sweep(None, GRID, t_end=T_END, transient=TRANSIENT, dt=DT, out=out, workers=2,
                 progress=False, on_rows=lambda batch: redone.extend(r["run"] for r in batch))
    assert sorted(redone) == [2, 3, 4, 5]
    assert_same_rows(rows, serial_rows)
    assert_same_rows(read_table(out), serial_rows)
    # a complete sweep run again computes nothing
    again = sweep(None, GRID, t_end=T_END, transient=TRANSIENT, dt=DT, out=out, workers=1,
                  progress=False, on_rows=lambda batch: pytest.fail("nothing to run"))
    assert [r["wall_s"] for r in again] == [r["wall_s"] for r in rows]


def test_a_different_sweep_is_refused_unless_overwrite(tmp_path):
    out = tmp_path / "sweep.csv"
    grid = {"flow.u": [0.1, 0.2]}
    sweep(None, grid, t_end=T_END, dt=DT, out=out, workers=1, progress=False)
    for kwargs, differs in (({"grid": {"flow.u": [0.1, 0.25]}}, "grid"),
                            ({"t_end": 3.0}, "t_end"), ({"transient": 1.0}, "transient"),
                            ({"base": Scene(ice_M=800.0)}, "base")):
        settings = {"base": None, "grid": grid, "t_end": T_END, **kwargs}
        with pytest.raises(SweepError, match=f"differs in: {differs}.*--overwrite"):
            sweep(settings["base"], settings["grid"], t_end=settings["t_end"], dt=DT, out=out,
                  transient=kwargs.get("transient", 0.0), workers=1, progress=False)
    rows = sweep(None, {"flow.u": [0.1, 0.25]}, t_end=T_END, dt=DT, out=out, workers=1,
                 progress=False, overwrite=True)
    assert [r["flow.u"] for r in read_table(out)] == [0.1, 0.25] == [r["flow.u"] for r in rows]


def test_a_table_without_metadata_is_not_appended_to(tmp_path):
    out = tmp_path / "sweep.csv"
    out.write_text("a,b\n1,2\n")
    with pytest.raises(SweepError, match="no metadata"):
        sweep(None, {"flow.u": [0.1]}, t_end=T_END, dt=DT, out=out, progress=False)
    assert out.read_text() == "a,b\n1,2\n"


def test_a_tampered_row_is_detected(tmp_path):
    out = tmp_path / "sweep.csv"
    sweep(None, {"flow.u": [0.1, 0.2]}, t_end=T_END, dt=DT, out=out, workers=1, progress=False)
    out.write_text(out.read_text().replace("\n1,0.2,", "\n1,0.3,"))
    with pytest.raises(SweepError, match="run 1 has parameter values"):
        sweep(None, {"flow.u": [0.1, 0.2]}, t_end=T_END, dt=DT, out=out, workers=1,
              progress=False)


def test_parquet_without_pyarrow_is_a_clear_error(tmp_path, monkeypatch):
    import builtins

    real_import = builtins.__import__

    def no_pyarrow(name, *args, **kwargs):
        if name.split(".")[0] == "pyarrow":
            raise ImportError(name)
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_pyarrow)
    with pytest.raises(SweepError, match="pip install pyarrow"):
        sweep(None, {"flow.u": [0.1]}, t_end=T_END, dt=DT, out=tmp_path / "s.parquet",
              progress=False)
    assert not (tmp_path / "s.parquet").exists()


def test_parquet_round_trip_and_resume(tmp_path, serial_rows):
    pytest.importorskip("pyarrow")
    out = tmp_path / "sweep.parquet"

    def interrupt(batch):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        sweep(None, GRID, t_end=T_END, transient=TRANSIENT, dt=DT, out=out, workers=1,
              chunksize=1, progress=False, on_rows=interrupt)
    rows = sweep(None, GRID, t_end=T_END, transient=TRANSIENT, dt=DT, out=out, workers=1,
                 progress=False)
    assert_same_rows(rows, serial_rows)
    assert_same_rows(read_table(out), serial_rows)
    assert not (tmp_path / "sweep.parquet.partial.csv").exists()


def test_dask_equals_serial(serial_rows):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(processes=False, n_workers=1, threads_per_worker=2,
                                  dashboard_address=None) as cluster:
        rows = sweep(None, GRID, t_end=T_END, transient=TRANSIENT, dt=DT, progress=False,
                     dask_address=cluster.scheduler_address)
    assert_same_rows(rows, serial_rows)


def test_dask_missing_is_a_clear_error(monkeypatch):
    import builtins

    real_import = builtins.__import__

    def no_dask(name, *args, **kwargs):
        if name.split(".")[0] in ("dask", "distributed"):
            raise ImportError(name)
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_dask)
    with pytest.raises(SweepError, match=r"pip install 'iceimpact\[dask\]'"):
        sweep(None, {"flow.u": [0.1]}, t_end=T_END, dt=DT, progress=False,
              dask_address="tcp://127.0.0.1:1")


# Bad input ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("spec,words", [
    ("flow.u=0:1:1000000000", "COUNT 1,000,000,000 is more than the 100,000 runs"),
    ("flow.u=log:1:2:100001", "COUNT 100,001 is more than"),
    ("flow.u=0:1:" + "9" * 5000, "is not an integer"),
    ("flow.u=0:1e309:3", "'1e309' is not finite"),
    ("flow.u=-1e308:1e308:3", "overflows"),
    ("ice.mass=1,2", "unknown parameter 'ice.mass' (did you mean 'ice.M'"),
    ("Flow.U=1,2", "(did you mean 'flow.u'?)"),
])
def test_absurd_axes_are_refused_before_allocating(spec, words):
    with pytest.raises(SweepError) as err:
        parse_vary(spec)
    assert words in str(err.value)
    assert "--vary '" + spec[:10] in str(err.value)
    assert len(str(err.value)) < 600   # a 5000-digit argument is not repeated in full


def test_grid_size_limit_and_max_runs():
    # refused on the product of the axis lengths, before any point is made
    grid = {"flow.u": list(range(1, 1001)), "ice.M": list(range(1, 1001))}
    with pytest.raises(SweepError, match=r"1,000,000 runs \(1,000 x 1,000\).*--max-runs"):
        sweep(None, grid, t_end=1.0, progress=False)
    with pytest.raises(SweepError, match="more than 3 values"):
        sweep(None, {"flow.u": iter(lambda: 0.1, None)}, t_end=1.0, progress=False,
              max_runs=3)   # an endless iterator is refused, not read to the end
    with pytest.raises(SweepError, match="max_runs"):
        sweep(None, {"flow.u": [0.1]}, t_end=1.0, progress=False, max_runs=0)
    assert check_grid_size({"flow.u": [0.1] * 10, "ice.M": [1.0] * 10}, max_runs=100) == 100
    assert parse_vary("flow.u=0:1:200001", max_count=200_001)[1][-1] == 1.0
    rows = sweep(None, {"flow.u": [0.1, 0.2], "impact.e": [1.0]}, t_end=T_END, dt=DT,
                 workers=1, progress=False, max_runs=2)
    assert len(rows) == 2
    with pytest.raises(SweepError, match="2 values, more than the limit of 1 runs"):
        sweep(None, {"flow.u": [0.1, 0.2]}, t_end=T_END, dt=DT, progress=False, max_runs=1)


def test_huge_numbers_are_clean_errors():
    with pytest.raises(SweepError, match="not finite"):
        parse_set("ice.M=1e400")
    # an absurd integer stays a float: messages print 1e+30, not 31 digits
    assert parse_set("solver.method=1e30") == ("solver.method", 1e30)
    with pytest.raises(SweepError, match="samples per run"):
        sweep(None, {"flow.u": [0.1]}, t_end=1e6, dt=1e-9, progress=False)
    (row,) = sweep(None, {"solver.method": [1e30]}, t_end=T_END, dt=DT, workers=1,
                   progress=False)
    assert row["status"].startswith("solver.method = 1e+30 is not allowed: 1, 2 or 3")


def test_integer_columns_are_ints(tmp_path):
    out = tmp_path / "sweep.csv"
    rows = sweep(None, {"drag.model": [1, 2], "impact.e": [0.5, 1.5]}, t_end=T_END, dt=DT,
                 out=out, workers=1, progress=False)
    for row in rows:
        assert type(row["run"]) is int and type(row["drag.model"]) is int
        if row["status"] == "ok":
            assert all(type(row[k]) is int for k in ("n_impacts", "nearest_n", "locked"))
        else:
            assert math.isnan(row["n_impacts"])
        assert type(row["x_peak_m"]) is float
    table = read_csv(out)
    column = table[0].index("n_impacts")
    assert table[1][column] == str(rows[0]["n_impacts"]) and "." not in table[1][column]
    assert table[2][column] == "nan"
    assert_same_rows(read_table(out), rows)
    meta = json.loads(meta_path(out).read_text())
    assert meta["column_types"]["n_impacts"] == "int"
    assert meta["column_types"]["x_peak_m"] == "float"


def test_parquet_integer_dtypes(tmp_path):
    pa = pytest.importorskip("pyarrow")
    import pyarrow.parquet as pq

    out = tmp_path / "sweep.parquet"
    rows = sweep(None, {"drag.model": [1, 2], "impact.e": [0.5, 1.5]}, t_end=T_END, dt=DT,
                 out=out, workers=1, progress=False)
    schema = pq.read_schema(out)
    for name in ("run", "drag.model", "n_impacts", "nearest_n", "locked"):
        assert schema.field(name).type == pa.int64(), name
    assert schema.field("impact.e").type == pa.float64()
    assert_same_rows(read_table(out), rows)


def test_an_old_table_with_float_counts_resumes_with_ints(tmp_path, serial_rows):
    """A table of format 1 (counts written as 3.0, no column types) resumes; ints afterwards."""
    out = tmp_path / "sweep.csv"
    sweep(None, GRID, t_end=T_END, transient=TRANSIENT, dt=DT, out=out, workers=1,
          progress=False)
    lines = out.read_text().splitlines(keepends=True)
    header = lines[0].rstrip("\n").split(",")
    ints = [header.index(k) for k in ("n_impacts", "nearest_n", "locked")]

    def as_float(line):
        cells = line.rstrip("\n").split(",")
        for i in ints:
            cells[i] = repr(float(cells[i]))
        return ",".join(cells) + "\n"

    out.write_text(lines[0] + "".join(as_float(line) for line in lines[1:4]))
    meta = json.loads(meta_path(out).read_text())
    del meta["column_types"]
    meta["format_version"] = 1
    meta_path(out).write_text(json.dumps(meta))
    rows = sweep(None, GRID, t_end=T_END, transient=TRANSIENT, dt=DT, out=out, workers=1,
                 progress=False)
    assert_same_rows(rows, serial_rows)
    assert all(type(r["n_impacts"]) is int for r in read_table(out))


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_planted_symlinks_at_temporary_names_are_not_followed(tmp_path, fmt):
    if fmt == "parquet":
        pytest.importorskip("pyarrow")
    out = tmp_path / f"sweep.{fmt}"
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n")
    planted = [out.with_name(out.name + s) for s in
               (".tmp", ".meta.json.tmp", ".partial.csv.tmp", ".partial.tmp")]
    for link in planted:
        link.symlink_to(victim)

    def interrupt(batch):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):   # a journal and metadata, then resumed
        sweep(None, {"flow.u": [0.1, 0.2]}, t_end=T_END, dt=DT, out=out, workers=1,
              chunksize=1, progress=False, on_rows=interrupt)
    sweep(None, {"flow.u": [0.1, 0.2]}, t_end=T_END, dt=DT, out=out, workers=1, progress=False)
    assert victim.read_text() == "precious\n"
    assert all(link.is_symlink() for link in planted)
    assert len(read_table(out)) == 2
    # no temporary file is left behind
    names = {p.name for p in tmp_path.iterdir()}
    assert names == {out.name, meta_path(out).name, victim.name, *(p.name for p in planted)}


def test_new_files_get_the_usual_permissions(tmp_path):
    out = tmp_path / "sweep.csv"
    sweep(None, {"flow.u": [0.1]}, t_end=T_END, dt=DT, out=out, workers=1, progress=False)
    umask = os.umask(0)
    os.umask(umask)
    assert out.stat().st_mode & 0o777 == 0o666 & ~umask
    assert meta_path(out).stat().st_mode & 0o777 == 0o666 & ~umask


# Damaged journals --------------------------------------------------------------------------------
def snapshot(directory):
    return {p.name: p.read_bytes() for p in sorted(directory.iterdir()) if p.is_file()}


@pytest.fixture(scope="module")
def small_sweep(tmp_path_factory):
    """A complete 4-run sweep: its files' bytes and its rows."""
    out = tmp_path_factory.mktemp("small") / "sweep.csv"
    rows = sweep(None, SMALL_GRID, t_end=T_END, dt=DT, out=out, workers=1, progress=False)
    return out.read_bytes(), meta_path(out).read_bytes(), rows


SMALL_GRID = {"flow.u": [0.1, 0.2, 0.3, 0.4]}


def resume_small(out):
    return sweep(None, SMALL_GRID, t_end=T_END, dt=DT, out=out, workers=1, progress=False)


@pytest.mark.parametrize("damage,words", [
    (lambda t, m: (t.replace(b"\n2,", b"\n2,,"), m), "line 4 has"),
    (lambda t, m: (t.replace(b"\n2,0.3,ok,", b"\n2,0.3,ok,abc"), m), "line 4, column wall_s"),
    (lambda t, m: (t.replace(b"\n3,", b"\n9,"), m), "line 5: run index 9 is outside"),
    (lambda t, m: (t.replace(b"\n3,", b"\n-3,"), m), "line 5, column run"),
    (lambda t, m: (t.replace(b"\n1,0.2,", b"\n1,0.25,"), m), "line 3: the row of run 1"),
    (lambda t, m: (t + t.split(b"\n")[2].replace(b",ok,", b",fail,") + b"\n", m),
     "run 1 appears twice"),
    (lambda t, m: (t.replace(b"run,", b"rum,"), m), "header"),
    (lambda t, m: (b"\x00\xff" * 50, m), "not UTF-8"),
    (lambda t, m: (t.replace(b",ok,", b',"' + b"x" * 200_000 + b'",', 1), m),
     "line 2 is not valid CSV"),
    (lambda t, m: (t, m[: len(m) // 2]), "is not valid JSON"),
    (lambda t, m: (t, b"[" * 100000), "meta.json"),
    (lambda t, m: (t, b'{"format": "iceimpact-sweep", "format_version": 99, "settings": {}}'),
     "newer"),
    (lambda t, m: (t, b"{}"), "not a sweep metadata file"),
    (lambda t, m: (t, m.replace(b'"settings"', b'"Settings"')), "settings"),
    (lambda t, m: (t, m.replace(b"0.4", b"0.5")), "different sweep (differs in: grid"),
])
def test_a_damaged_journal_is_refused_and_left_untouched(tmp_path, small_sweep, damage, words):
    table, meta, _ = small_sweep
    out = tmp_path / "sweep.csv"
    table, meta = damage(table, meta)
    out.write_bytes(table)
    meta_path(out).write_bytes(meta)
    before = snapshot(tmp_path)
    with pytest.raises(SweepError) as err:
        resume_small(out)
    assert words in str(err.value)
    assert str(out) in str(err.value)
    assert snapshot(tmp_path) == before   # nothing written, nothing lost


def test_metadata_that_is_a_directory_is_refused(tmp_path, small_sweep):
    out = tmp_path / "sweep.csv"
    out.write_bytes(small_sweep[0])
    meta_path(out).mkdir()
    with pytest.raises(SweepError, match="not a regular file"):
        resume_small(out)
    assert out.read_bytes() == small_sweep[0]


def check_fuzzed_outcome(out, damaged_table, before, reference):
    """After a resume of a damaged journal: either a refusal that changed nothing, or a complete
    table that kept every complete line of the damaged journal (checked by the caller's
    attempt) and has every run once, with the grid's values."""
    try:
        rows = resume_small(out)
    except SweepError as exc:
        assert str(out) in str(exc) or "different sweep" in str(exc)
        assert snapshot(out.parent) == before
        return "refused"
    assert [r["run"] for r in rows] == list(range(4))
    assert [r["flow.u"] for r in rows] == SMALL_GRID["flow.u"]
    assert_same_rows(read_table(out), rows)
    # every complete line of the damaged journal is kept, value for value
    text = damaged_table.decode("utf-8")
    complete = text[: text.rfind("\n") + 1]
    lines = list(csv.reader(complete.splitlines()))
    for fields in lines[1:]:
        row = rows[int(fields[0])]
        for column, cell in zip(lines[0], fields, strict=True):
            value = row[column]
            if column == "status":
                assert value == cell
            else:
                assert same({"v": float(value)}, {"v": float(cell)}), (column, cell, value)
    # the runs that were not in it equal a fresh sweep's
    kept = {int(f[0]) for f in lines[1:]}
    for index in set(range(4)) - kept:
        assert same(rows[index], reference[index])
    return "resumed"


def test_fuzzed_journals_are_refused_or_resumed_never_lost(tmp_path, small_sweep):
    """Random bytes, truncations and bit flips of a valid table and metadata file."""
    table, meta, reference = small_sweep
    rng = np.random.default_rng(20240601)
    outcomes = {"refused": 0, "resumed": 0}
    cases = []
    for _ in range(15):
        cases.append((rng.bytes(int(rng.integers(0, 400))), meta))
        cases.append((table, rng.bytes(int(rng.integers(0, 400)))))
    for cut in rng.integers(0, len(table), 20):
        cases.append((table[:cut], meta))
    for cut in rng.integers(0, len(meta), 10):
        cases.append((table, meta[:cut]))
    for _ in range(40):
        which = int(rng.integers(0, 2))
        data = bytearray((table, meta)[which])
        pos = int(rng.integers(0, len(data)))
        data[pos] ^= 1 << int(rng.integers(0, 8))
        cases.append((bytes(data), meta) if which == 0 else (table, bytes(data)))
    for i, (damaged_table, damaged_meta) in enumerate(cases):
        directory = tmp_path / f"case{i}"
        directory.mkdir()
        out = directory / "sweep.csv"
        out.write_bytes(damaged_table)
        meta_path(out).write_bytes(damaged_meta)
        before = snapshot(directory)
        outcomes[check_fuzzed_outcome(out, damaged_table, before, reference)] += 1
    assert outcomes["refused"] > 10 and outcomes["resumed"] > 10, outcomes


def test_fuzzed_parquet_tables_are_refused(tmp_path):
    pytest.importorskip("pyarrow")
    out = tmp_path / "sweep.parquet"
    sweep(None, SMALL_GRID, t_end=T_END, dt=DT, out=out, workers=1, progress=False)
    good = out.read_bytes()
    rng = np.random.default_rng(7)
    for damaged in [good[: len(good) // 2], rng.bytes(300), good[:8] + rng.bytes(200) + good[-8:]]:
        out.write_bytes(damaged)
        with pytest.raises(SweepError, match="sweep.parquet: is not a readable Parquet"):
            resume_small_parquet(out)
        assert out.read_bytes() == damaged


def resume_small_parquet(out):
    return sweep(None, SMALL_GRID, t_end=T_END, dt=DT, out=out, workers=1, progress=False)


# Layers ------------------------------------------------------------------------------------------
def test_package_modules_import_on_their_own_without_cycles():
    """Each module of the package imports first in a fresh interpreter (a cycle would fail)."""
    modules = ["iceimpact.runspec", "iceimpact.sweep.errors", "iceimpact.sweep.grid",
               "iceimpact.sweep.columns", "iceimpact.sweep.runner", "iceimpact.sweep.table",
               "iceimpact.sweep.backends", "iceimpact.sweep"]
    code = "import importlib, sys\nfor m in sys.argv[1:]:\n    importlib.import_module(m)\n"
    for module in modules:
        proc = subprocess.run([sys.executable, "-c", code, module], capture_output=True,
                              text=True, timeout=120)
        assert proc.returncode == 0, (module, proc.stderr)
    # runspec is below the sweep package
    proc = subprocess.run([sys.executable, "-c", "import sys, iceimpact.runspec; "
                           "print('iceimpact.sweep' in sys.modules)"], capture_output=True,
                          text=True, timeout=120)
    assert proc.stdout.strip() == "False"


_FAULTS = """
import resource, sys
import numpy as np
from iceimpact.sweep import backends
kept = backends.keep_freed_memory() if sys.argv[1] == "keep" else None
def faults():
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt
a = np.ones(1_000_000)  # 8 MB, as a long run's arrays
del a
before = faults()
for _ in range(20):
    a, b = np.ones(1_000_000), np.ones(1_000_000)
    del a, b
print(kept, faults() - before)
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's malloc")
def test_a_process_of_many_runs_keeps_its_freed_memory():
    """keep_freed_memory (the pool's workers, the command line) has malloc reuse the memory of
    the arrays a run frees: 20 rounds of two 8 MB arrays take some hundreds of page faults (one
    per page would be 80,000); without it, measured, 16,000 to 27,000."""
    def run_with(mode: str) -> tuple[str, int]:
        proc = subprocess.run([sys.executable, "-c", _FAULTS, mode], capture_output=True,
                              text=True, check=True)
        kept, faults = proc.stdout.split()
        return kept, int(faults)
    kept, faults = run_with("keep")
    default_kept, default_faults = run_with("default")
    assert kept == "True" and default_kept == "None"
    assert faults < 2_000 and 5 * faults < default_faults
