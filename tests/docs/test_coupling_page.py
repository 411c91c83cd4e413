"""docs/explanation/coupling.md's early-return table is what today's masters give.

Each row (scene, communication step) quotes, for the plain, early and early+approach masters,
the x error, the impact-time error (impacts at a step start left out, against the monolithic
run's impacts with its Zeno sequences closed) and the leading impacts, as
``benchmarks/coupling_early_return.py`` measures them through FMPy and the core. The test runs the
core masters (equal to the FMU masters to 1e-9, ``tests/system/test_early_return_master.py``) and
compares each printed number within half a unit of its last digit; about 5 s.
"""

from __future__ import annotations

import re
from pathlib import Path

import coupling_early_return as bench
import numpy as np
import pytest
from coupling import SCENES, T_END, impacts_as_external

from iceimpact import Scene
from iceimpact.simulator import run

ROOT = Path(__file__).resolve().parents[2]
COUPLING = ROOT / "docs" / "explanation" / "coupling.md"


def early_return_rows() -> list[list[str]]:
    """The cells of the early-return table's rows."""
    text = COUPLING.read_text().split("### Early return", 1)[1]
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("| scene"))
    end = next(i for i in range(start, len(lines)) if not lines[i].startswith("|"))
    rows = lines[start:end]
    return [[c.strip() for c in row.strip("|").split("|")] for row in rows[2:]]


def close(printed: str, value: float) -> bool:
    """``value`` rounds to ``printed`` (within half a unit of its last digit)."""
    digits = printed.split(".")[1] if "." in printed else ""
    unit = 10.0 ** -len(digits)
    if not digits:  # an integer with trailing zeros is quoted to its significant digits
        unit = 10.0 ** (len(printed) - len(printed.rstrip("0")))
    return abs(float(printed) - value) <= unit / 2 * (1 + 1e-9)


def test_the_table_has_both_scenes_at_three_steps() -> None:
    rows = early_return_rows()
    assert [(r[0], r[1]) for r in rows] == [(s, h) for s in ("impacting", "heavy")
                                            for h in ("10 ms", "3 ms", "1 ms")]


@pytest.mark.parametrize("row", early_return_rows(), ids=lambda r: f"{r[0]}-{r[1]}")
def test_early_return_row_is_the_masters(row: list[str]) -> None:
    scene_name, step, x_errors, times, leading = row
    values = next(v for name, v in SCENES.items() if name.startswith(scene_name))
    scene = Scene(**values)
    h = float(step.split()[0]) * 1e-3
    mono = run(scene, T_END, dt=h)
    reference = impacts_as_external(scene, h)
    measured = [bench.row_of(bench.core_master(scene, T_END, h, master), mono, 0.0, reference)
                for master in bench.MASTERS]
    for printed, m in zip(x_errors.split(" / "), measured, strict=True):
        assert close(printed.rstrip("%"), 100 * m["x_error"]), (row, printed, m["x_error"])
    dts = [1e3 * m["impact_dt_in_order_real"] for m in measured]
    if times.startswith("all > "):
        bound = float(re.findall(r"[\d.]+", times)[0]) * 1e3
        assert all(dt > bound for dt in dts), (row, dts)
    else:
        for printed, dt in zip(times.removesuffix(" ms").split(" / "), dts, strict=True):
            assert close(printed, dt), (row, printed, dt)
    assert [int(n) for n in leading.split(" / ")] == [m["leading_impacts"] for m in measured]
    assert np.all(np.isfinite(dts))


def test_the_example_measures_as_the_table() -> None:
    """examples/system/early_return.py matches impacts against the same reference as the table
    (the monolithic run's Zeno sequences closed), so its column prints the table's numbers."""
    import early_return

    scene = Scene(**next(iter(SCENES.values())))
    assert np.array_equal(early_return.reachable_impacts(scene, T_END, 1e-2),
                          impacts_as_external(scene, 1e-2))
