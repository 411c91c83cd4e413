"""The sweep tests' fixture: the serial rows of the shared grid (tests/sweep_rows.py)."""

from __future__ import annotations

import pytest

from iceimpact.sweep import sweep
from sweep_rows import DT, GRID, T_END, TRANSIENT


@pytest.fixture(scope="module")
def serial_rows() -> list[dict]:
    """The grid run in this process, one worker: the rows every other way must give."""
    return sweep(None, GRID, t_end=T_END, transient=TRANSIENT, dt=DT, workers=1, progress=False)
