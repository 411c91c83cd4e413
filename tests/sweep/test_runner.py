"""One run -> one row (iceimpact.sweep.runner): rows equal direct runs, the base scene kept, an
invalid combination an error row, a custom measure's columns."""

from __future__ import annotations

import math

from iceimpact import Scene, run
from iceimpact.studies.analysis import SUMMARY_FIELDS, summarize
from iceimpact.sweep import grid_points, sweep
from sweep_rows import DT, GRID, T_END, TRANSIENT, same


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
