"""A host's slips with FMU states are errors, never crashes: the loader (fmu_native/loader.c)
checks every state argument against the states it handed out before PythonFMU dereferences it.

fmusim (the FMI standard's reference C master, ../shared/tools/fmusim) frees a state it saved to
a file by passing the state handle itself to fmi2FreeFMUstate / fmi3FreeFMUState, which take a
pointer to it: the loader frees that state with a warning in the log and succeeds, so that the
save completes; anything else that is not a live state of the instance is refused with fmi2Error
and a message."""

from __future__ import annotations

import csv
import subprocess
from ctypes import byref, c_void_p

import numpy as np
import pytest
from fmpy import simulate_fmu

from fmu_host import FMI_ERROR, FMI_OK, Instance
from native_host import FMUSIM, FMUSIM_ABSENT, FMUSIM_STATEFIX


def _raw(inst: Instance, name: str):
    """The FMU's own function ``name`` (no FMPy wrapper: a host's exact arguments reach it)."""
    function = getattr(inst.fmu.dll, name)
    function.restype = int
    return function


def test_a_state_passed_by_value_a_freed_one_and_a_stranger_are_errors_not_crashes(
        fmu_dir, model_description):
    inst = Instance(fmu_dir, model_description)
    assert inst.initialize() == FMI_OK
    inst.run(10)
    component = inst.fmu.component
    free = _raw(inst, "fmi2FreeFMUstate")
    free.argtypes = [c_void_p, c_void_p]
    get = _raw(inst, "fmi2GetFMUstate")
    get.argtypes = [c_void_p, c_void_p]
    set_state = _raw(inst, "fmi2SetFMUstate")
    set_state.argtypes = [c_void_p, c_void_p]

    # the handle itself, as fmusim passes it: freed, with a warning, and OK
    state = c_void_p()
    assert get(component, byref(state)) == FMI_OK and state.value
    assert free(component, state.value) == FMI_OK
    assert any("itself, not a pointer to it" in m for s, _, m in inst.messages if s == 1)
    # that state is gone: setting it, or freeing it again properly, is refused
    before = len(inst.messages)
    assert set_state(component, state.value) == FMI_ERROR
    assert free(component, byref(state)) == FMI_ERROR
    refusals = [m for s, _, m in inst.messages[before:] if s == FMI_ERROR]
    assert len(refusals) == 2 and all("not one this instance handed out" in m
                                      for m in refusals), refusals
    # a handle the FMU never handed out, and a NULL pointer
    stranger = c_void_p(0xDEADBEEF)
    assert free(component, byref(stranger)) == FMI_ERROR
    assert set_state(component, stranger.value) == FMI_ERROR
    assert free(component, None) == FMI_ERROR
    # a NULL state to free is nothing to do (FMI 2.0)
    assert free(component, byref(c_void_p())) == FMI_OK
    # a state got and freed properly still works, and the host goes on
    good = c_void_p()
    assert get(component, byref(good)) == FMI_OK
    assert set_state(component, good.value) == FMI_OK
    assert free(component, byref(good)) == FMI_OK and good.value is None
    assert inst.run(10, start_index=10)[-1]["structure.x"] == inst.outputs()["structure.x"]
    inst.free()


def test_fmi3_state_slips_are_errors_not_crashes(fmu3_dir):
    from fmpy import read_model_description
    from fmpy.fmi3 import FMU3Slave

    md = read_model_description(fmu3_dir)
    fmu = FMU3Slave(guid=md.guid, unzipDirectory=fmu3_dir,
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="slips")
    fmu.instantiate()
    try:
        fmu.enterInitializationMode(startTime=0.0)
        fmu.exitInitializationMode()
        fmu.doStep(0.0, 0.01)
        free = fmu.dll.fmi3FreeFMUState
        free.argtypes, free.restype = [c_void_p, c_void_p], int
        state = fmu.getFMUState().value
        assert free(fmu.component, state) == FMI_OK  # the handle itself: freed, OK
        assert free(fmu.component, byref(c_void_p(state))) == FMI_ERROR  # freed already
        assert free(fmu.component, byref(c_void_p(0xDEADBEEF))) == FMI_ERROR
        fmu.doStep(0.01, 0.01)  # the instance goes on
    finally:
        fmu.terminate()
        fmu.freeInstance()


def _fmusim(binary, fmu, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(binary), *args, str(fmu)], capture_output=True, text=True,
                          timeout=300)


def _csv(path) -> dict[str, np.ndarray]:
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    names = [n.strip('"') for n in rows[0]]
    data = np.array([[float(v) for v in row] for row in rows[1:]])
    return {name: data[:, i] for i, name in enumerate(names)}


@pytest.mark.skipif(FMUSIM is None, reason=FMUSIM_ABSENT)
@pytest.mark.parametrize("which", ["FMI 2.0", "FMI 3.0"])
def test_fmusim_saves_and_restores_a_state_and_runs_as_fmpy(which, fmu, fmu3, tmp_path):
    """fmusim's save of the final state (the handle passed by value to the free function)
    completes with a warning; its runs equal FMPy's to the bit; the state restored by fmusim (and
    by the fixed fmusim) continues as one run through."""
    path = fmu if which == "FMI 2.0" else fmu3
    grid = ("--output-interval", "0.01")
    whole = _fmusim(FMUSIM, path, "--stop-time", "2", *grid, "--output-file",
                    str(tmp_path / "whole.csv"))
    assert whole.returncode == 0, whole.stderr
    first = _fmusim(FMUSIM, path, "--stop-time", "1", *grid, "--final-fmu-state-file",
                    str(tmp_path / "s.bin"), "--output-file", str(tmp_path / "first.csv"))
    assert first.returncode == 0, first.stdout + first.stderr
    assert "itself, not a pointer to it" in first.stdout + first.stderr
    second = _fmusim(FMUSIM, path, "--start-time", "1", "--stop-time", "2", *grid,
                     "--initial-fmu-state-file", str(tmp_path / "s.bin"), "--output-file",
                     str(tmp_path / "second.csv"))
    assert second.returncode == 0, second.stdout + second.stderr
    full, later = _csv(tmp_path / "whole.csv"), _csv(tmp_path / "second.csv")
    # (the grids differ in the last bits: k * 0.01 summed from 0, or from 1)
    rows = np.isin(np.round(full["time"], 9), np.round(later["time"], 9))
    assert rows.sum() == len(later["time"]) == 101
    np.testing.assert_allclose(later["structure.x"], full["structure.x"][rows], rtol=0,
                               atol=1e-12 * np.max(np.abs(full["structure.x"])))
    fmpy = simulate_fmu(str(path), stop_time=2.0, output_interval=0.01)
    assert np.array_equal(fmpy["structure.x"], full["structure.x"])
    if FMUSIM_STATEFIX is not None:  # the state a correct host saves is the same bytes
        fixed = _fmusim(FMUSIM_STATEFIX, path, "--stop-time", "1", *grid,
                        "--final-fmu-state-file", str(tmp_path / "s_fixed.bin"),
                        "--output-file", str(tmp_path / "fixed.csv"))
        assert fixed.returncode == 0, fixed.stderr
        assert (tmp_path / "s_fixed.bin").read_bytes() == (tmp_path / "s.bin").read_bytes()
