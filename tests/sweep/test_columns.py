"""Column types (iceimpact.sweep.columns): whole-number columns are ints in the rows, in the CSV
table, in its metadata and as Parquet int64."""

from __future__ import annotations

import json
import math

import pytest

from iceimpact.sweep import meta_path, read_table, sweep
from sweep_rows import DT, T_END, assert_same_rows, read_csv


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
