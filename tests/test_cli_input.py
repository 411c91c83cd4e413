"""Fuzzing of the command line's arguments: a clear message and exit status, never a traceback."""

from __future__ import annotations

import contextlib
import io

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from iceimpact import ParameterError, Scene
from iceimpact.cli import main as cli_main
from iceimpact.fmi.adapter import FmuModel

# --- fuzz: CLI arguments ------------------------------------------------------------------

def _cli(argv: list[str]) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            status = cli_main(argv)
        except SystemExit as exc:
            status = exc.code
    return status, err.getvalue()


_VALUES = st.one_of(
    st.sampled_from(["nan", "inf", "-inf", "1e400", "-1e400", "0", "-0", "-1", "1e-400",
                     "9" * 5000, "", " ", "1e40", "1e12", "0x10", "1_000", "true", "=",
                     "1,5", "\x00", "１"]),
    st.text(max_size=12), st.floats(allow_nan=True, allow_infinity=True).map(repr))
_NAMES = st.one_of(st.sampled_from(["structure.k", "ice.M", "flow.u", "drag.model",
                                    "solver.method", "impact.e", "solver.dt", "ice.mass", "",
                                    " ice.M ", "structure"]), st.text(max_size=8))


@settings(max_examples=60, deadline=None, derandomize=True)
@given(name=_NAMES, value=_VALUES, option=st.sampled_from(["--set", "--t-end", "--dt"]))
def test_cli_bad_arguments_exit_2_with_a_message(name, value, option):
    arg = f"{name}={value}" if option == "--set" else value
    argv = ["simulate", option, arg, "--t-end", "1e-3", "--dt", "1e-3"]
    if option != "--set":
        argv = ["simulate", "--t-end", "1e-3", "--dt", "1e-3", option, arg]
    status, err = _cli(argv)
    if status == 0:  # a valid value: the run went through
        return
    assert status == 2, (argv, status, err)
    assert "error:" in err and "Traceback" not in err, err


def test_underflowing_scales_are_a_parameter_error_not_a_zero_division():
    """structure.k = structure.m = 1e-200 raised a bare ZeroDivisionError (sqrt(k m) = 0):
    a ParameterError naming the combination, in Python, through the CLI and through the FMU."""
    with pytest.raises(ParameterError, match=r"zeta\^2 = .* = inf is not allowed"):
        Scene(structure_k=1e-200, structure_m=1e-200)
    status, err = _cli(["simulate", "--set", "structure.k=1e-200", "--set", "structure.m=1e-200",
                        "--t-end", "1e-3", "--dt", "1e-3"])
    assert status == 2 and "zeta^2" in err and "Traceback" not in err
    logs: list[str] = []
    fmu = FmuModel(lambda status, text: logs.append(text))
    fmu.set("structure.k", 1e-200)
    fmu.set("structure.m", 1e-200)
    fmu.initialize()
    assert not fmu.do_step(0.0, 1e-3)
    assert any("zeta^2" in text for text in logs)


def test_cli_refuses_a_scene_it_cannot_run_in_bounded_time():
    status, err = _cli(["simulate", "--set", "structure.k=1e40", "--t-end", "1e-3",
                        "--dt", "1e-3"])
    assert status == 2 and "omega_n <=" in err and "Traceback" not in err
