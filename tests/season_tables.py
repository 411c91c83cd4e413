"""Load-case tables the seasons' tests share: a TOML table and its CSV twin, and rows and
tables made by hand for the closed forms."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from iceimpact.seasons import Case, CaseTable, series_row

TOML = """\
t_end = 6.0            # s
transient = 1.0
dt = 0.01
repetitions = 2
[defaults]
"drag.model" = 2
[[case]]
name = "slow drift"
hours = 300.0
repetitions = 3
"flow.u" = 0.1
"ice.M" = 1600.0
[[case]]
name = "fast floe"
hours = 100.0
flow.u = 0.5           # dotted keys are FMI names too
impact.e = 0.8
"""

CSV = """\
# the TOML table above, as a spreadsheet would write it
name,hours,repetitions,drag.model,flow.u,ice.M,impact.e
slow drift,300,3,2,0.1,1600,
fast floe,100,,2,0.5,,0.8
"""


def write(tmp_path: Path, text: str, name: str = "cases.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def cosine(amplitude: float, f: float, periods: int, fs: float = 64.0):
    """A cosine of ``periods`` whole periods from peak to peak: its rainflow ranges are all
    ``2 amplitude`` (N), ``periods`` cycles, so its 1 Hz DEL is ``2 A f^(1/m)``."""
    t = np.arange(int(periods * fs) + 1) / (fs * f)
    return t, amplitude * np.cos(2 * np.pi * f * t)


def rows_of(series: list[list[tuple[np.ndarray, np.ndarray]]], **options) -> list[dict]:
    """Rows as the runs give them, from time series of k x (k = 1 N/m): series[case][rep]."""
    return [{"run": None, "case": i, "repetition": r, "status": "ok",
             **series_row(t, y, 1.0, **options)}
            for i, reps in enumerate(series) for r, (t, y) in enumerate(reps)]


def table_of(hours: list[float], reps: list[int] | None = None) -> CaseTable:
    reps = reps or [1] * len(hours)
    return CaseTable(cases=tuple(Case(f"c{i}", h, n) for i, (h, n)
                                 in enumerate(zip(hours, reps, strict=True))), t_end=1.0)

