"""The grid of a sweep (iceimpact.sweep.grid): axes from text, the grid's order, its checks
and its size limit, absurd and huge values refused before anything is allocated or run."""

from __future__ import annotations

import numpy as np
import pytest

from iceimpact.sweep import (
    SweepError,
    check_grid_size,
    grid_points,
    normalize_grid,
    parse_set,
    parse_values,
    parse_vary,
    sweep,
)
from sweep_rows import DT, T_END


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
