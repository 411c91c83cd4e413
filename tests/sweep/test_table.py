"""The table (iceimpact.sweep.table): CSV and Parquet written as runs finish, exact round trips,
resume after lost rows, a cut line or an interruption, refusals (another sweep's table, no
metadata, a tampered row, damaged or fuzzed journals), old tables, safe file writing."""

from __future__ import annotations

import csv
import json
import os

import numpy as np
import pytest

from iceimpact import Scene
from iceimpact.sweep import SweepError, meta_path, read_table, sweep
from sweep_rows import DT, GRID, T_END, TRANSIENT, assert_same_rows, read_csv, same


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
