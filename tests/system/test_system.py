"""The coupled system of examples/system/ through real masters: IceImpact.fmu (structure.model =
2) and ModalStructure.fmu (one mode equal to IceImpact's built-in structure) in a scripted FMPy
Gauss-Seidel master, a scripted FMPy Jacobi master, ECOS (ecospy, reading the SSP) and libcosim
(libcosimpy). Each is compared with IceImpact's own monolithic run (structure.model = 1) and the
Jacobi masters with each other.

ECOS's and libcosim's fixed-step algorithms are Jacobi schemes: every component steps from the
values exchanged at the step start, so the structure holds a step's contact force over the next
step; IceImpact is told so by ``coupling.scheme = 2`` (the SSP binds it). The SSP in all five
masters that load it (FMPy, ECOS, libcosim, OMSimulator's command line and Python API):
tests/system/test_ssp_masters.py.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import system

ROOT = Path(__file__).resolve().parents[2]

T_END = 2.0


@pytest.fixture(scope="module")
def jacobi_runs(fmus, tmp_path_factory) -> dict:
    """The three Jacobi masters and the monolithic run, h = 1 ms."""
    h = 1e-3
    runs = {"mono": system.monolithic(fmus, T_END, h),
            "fmpy": system.fmpy_master(fmus, T_END, h, "jacobi")}
    ecospy = pytest.importorskip("ecospy")
    assert ecospy
    ssp = system.write_ssp(fmus, tmp_path_factory.mktemp("ssp") / "IceOnStructure.ssp")
    runs["ecospy"] = system.ecospy_run(ssp, T_END, h)
    pytest.importorskip("libcosimpy")
    runs["libcosimpy"] = system.libcosimpy_run(fmus, T_END, h)
    return runs


def test_ecospy_on_the_ssp_and_libcosimpy_equal_the_fmpy_jacobi_master(jacobi_runs):
    reference = jacobi_runs["fmpy"]
    assert len(jacobi_runs["ecospy"]["x"]) == len(reference["x"])
    assert len(jacobi_runs["libcosimpy"]["x"]) == len(reference["x"])
    # ECOS steps exactly as the scripted loop: bit for bit; libcosim keeps time in integer
    # nanoseconds, so its step sizes differ from k h - (k-1) h in the last bits
    assert system.relative_error(jacobi_runs["ecospy"], reference) == 0.0
    assert system.relative_error(jacobi_runs["libcosimpy"], reference) < 1e-9


def test_jacobi_masters_follow_the_monolithic_run(jacobi_runs):
    """With coupling.scheme = 2 a Jacobi master no longer strikes again every step."""
    error = system.relative_error(jacobi_runs["ecospy"], jacobi_runs["mono"])
    assert error < 0.1, error
    steps_with_force = int((jacobi_runs["ecospy"]["force"] > 0.0).sum())
    assert steps_with_force < 20, steps_with_force


def test_fmu_masters_converge_with_the_step(fmus):
    """FMPy Gauss-Seidel and Jacobi through both FMUs: the error against the monolithic run falls
    at least 3x from h = 1 ms to 0.1 ms, and the two schemes agree within their difference."""
    errors = {}
    for h in (1e-3, 1e-4):
        mono = system.monolithic(fmus, T_END, h)
        for scheme in ("gauss-seidel", "jacobi"):
            errors[scheme, h] = system.relative_error(
                system.fmpy_master(fmus, T_END, h, scheme), mono)
    for scheme in ("gauss-seidel", "jacobi"):
        assert errors[scheme, 1e-3] / errors[scheme, 1e-4] >= 3.0, errors
    assert errors["gauss-seidel", 1e-4] < 0.02, errors
    assert errors["jacobi", 1e-4] < 0.02, errors
