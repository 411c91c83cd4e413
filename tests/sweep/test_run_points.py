"""The engine (iceimpact.sweep: sweep and run_points): settings checked before anything runs,
numpy settings, the test hook that pauses a sweep, and the package's layers."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from iceimpact.sweep import PAUSE_ENV, SweepError, read_table, sweep
from sweep_rows import DT, T_END, assert_same_rows


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


def test_the_pause_hook_stops_after_n_runs_and_is_checked(tmp_path, monkeypatch):
    """PAUSE_ENV=2: the sweep waits once 2 runs are written (here the wait raises, as Ctrl-C
    would); a bad value is refused before anything is written; unset, the sweep runs through."""
    import iceimpact.sweep as engine

    out, waits = tmp_path / "s.csv", []

    def interrupted(finished):
        waits.append((finished, len(read_table(out))))
        raise KeyboardInterrupt

    monkeypatch.setattr(engine, "_wait_to_be_stopped", interrupted)
    grid = {"flow.u": [0.1, 0.2, 0.3]}
    monkeypatch.setenv(PAUSE_ENV, "2")
    with pytest.raises(KeyboardInterrupt):
        sweep(None, grid, t_end=T_END, dt=DT, out=out, workers=1, chunksize=1, progress=False)
    assert waits == [(2, 2)]
    for bad in ("0", "two", "-1", "1.5"):
        monkeypatch.setenv(PAUSE_ENV, bad)
        with pytest.raises(SweepError, match=f"{PAUSE_ENV} = '{bad}': expected an integer"):
            sweep(None, grid, t_end=T_END, dt=DT, out=tmp_path / "bad.csv", progress=False)
        assert not (tmp_path / "bad.csv").exists()
    monkeypatch.delenv(PAUSE_ENV)
    assert len(sweep(None, grid, t_end=T_END, dt=DT, out=out, workers=1, progress=False)) == 3
    assert waits == [(2, 2)]


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
