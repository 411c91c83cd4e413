"""Sweep engine: grid specs, rows equal to direct runs, parallel = serial, resume, errors."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest

from iceimpact import Scene, run
from iceimpact.analysis import SUMMARY_FIELDS, summarize
from iceimpact.sweep import (
    SweepError,
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
    assert rows[1]["status"] == "drag.model = 3 is not allowed: 1 or 2"
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
