"""Every host's failure path ends in a message and a status, never a crash (fmu_native/loader.c).

Each failure is made by a host that does exactly what a real one does: the C host of
``tests/c_host/host.c`` on request (``-N``: every call on a NULL instance, as ECOS calls
fmi2SetupExperiment on the NULL a failed fmi2Instantiate returned; ``-S``: a logger that aborts
on a NULL category or instance name, as OMSimulator's does; ``-E``: exit without terminating;
``-P``: an embedded Python finalized before fmi2Terminate, as OMSimulator's static destructor
does at the exit of a Python script), then ECOS and OMSimulator themselves. "No numpy" is this
machine with every site-packages hidden (``native_host.without_numpy``).
"""

from __future__ import annotations

import os
import subprocess
import sys
import sysconfig
import textwrap
from pathlib import Path

import pytest

from native_host import (
    OMSIMULATOR,
    OMSIMULATOR_ABSENT,
    ecos_binary,
    parse_csv,
    run_empty_env,
    without_numpy,
    without_python,
)

FMI_ERROR = 3
CRASHES = (-6, -11, 134, 139)  # SIGABRT, SIGSEGV, as a return code or through a shell


def run(command: list[str], cwd: Path | None = None,
        env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(command, cwd=cwd, capture_output=True, text=True, timeout=300, env=env)


def null_statuses(stdout: str, prefix: str = "null ") -> dict[str, int]:
    return {line.split()[1]: int(line.split()[2]) for line in stdout.splitlines()
            if line.startswith(prefix) and "FreeInstance" not in line}


def test_every_call_on_a_null_instance_is_an_error_and_the_run_goes_on(c_host, fmu_dir):
    done = run_empty_env([str(c_host), fmu_dir, "-n", "5", "-N", "-o", "structure.x"])
    assert done.returncode == 0, done.stderr[-3000:]
    statuses = null_statuses(done.stdout)
    assert len(statuses) == 13 and set(statuses.values()) == {FMI_ERROR}, statuses
    assert "null fmi2FreeInstance done" in done.stdout
    # said once on stderr, not once a call
    assert done.stderr.count("was called with a NULL instance") <= 2, done.stderr
    assert len(parse_csv(done.stdout.split("null fmi2FreeInstance done\n")[1])["time"]) == 6


def test_without_numpy_the_reason_reaches_stderr_and_a_strict_logger(c_host, fmu_dir):
    """PythonFMU logs the failed start with a NULL category: a logger that aborts on NULL (as
    OMSimulator's does) gets logStatusFatal instead; then fmi2SetupExperiment on the NULL."""
    done = run(without_numpy([str(c_host), fmu_dir, "-n", "3", "-S", "-N"]))
    assert done.returncode == 3, done.stderr[-3000:]
    assert "cannot import numpy" in done.stderr
    assert "apt-get install python3-numpy python3-scipy" in done.stderr  # PEP 668 systems
    assert "[logStatusFatal]" in done.stderr
    assert "fmi2Instantiate of instance 'host' failed" in done.stderr
    assert "null-after-failure fmi2SetupExperiment 3" in done.stdout


def test_a_host_that_exits_without_terminating_exits_cleanly(c_host, fmu_dir):
    done = run_empty_env([str(c_host), fmu_dir, "-n", "200", "-s", "ice.M=800", "-E"])
    assert done.returncode == 0, done.stderr[-3000:]


@pytest.mark.skipif(not sysconfig.get_config_var("Py_ENABLE_SHARED"),
                    reason="this Python has no shared libpython for the C host to embed")
def test_calls_after_the_hosts_python_was_finalized_touch_nothing(c_host, fmu_dir):
    library = Path(sysconfig.get_config_var("LIBDIR")) / sysconfig.get_config_var("INSTSONAME")
    env = {"PYTHONHOME": sys.base_prefix} if sys.base_prefix != sys.prefix else {}
    done = run([str(c_host), fmu_dir, "-n", "1000", "-s", "ice.M=800", "-P", str(library),
                "-o", "contact.count"], env=env)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "after finalize: terminate 0" in done.stdout
    rows = parse_csv(done.stdout.split("after finalize")[0])
    assert rows["contact.count"][-1] > 0  # the FMU ran in the host's Python before


#: The two machines the default FMU cannot run on, and what it says on each.
MACHINES = {
    "no Python": (without_python, "needs the shared library of Python"),
    "Python without numpy": (without_numpy, "cannot import numpy"),
}


@pytest.mark.parametrize("machine", MACHINES)
def test_ecos_prints_the_reason_and_does_not_crash(fmu, tmp_path, machine):
    wrap, reason = MACHINES[machine]
    ecos = ecos_binary(tmp_path)
    done = run(wrap([str(ecos), "simulate", "--path", str(fmu), "--stopTime", "0.01",
                     "--stepSize", "0.001"]), cwd=tmp_path)
    assert done.returncode not in CRASHES, done.stderr[-3000:]
    assert reason in done.stderr  # ECOS shows FMU logs only with -l debug: the loader's stderr
    assert "fmi2SetupExperiment was called with a NULL instance" in done.stderr


@pytest.mark.skipif(OMSIMULATOR is None, reason=OMSIMULATOR_ABSENT)
@pytest.mark.parametrize("machine", MACHINES)
def test_omsimulator_shows_the_reason_and_does_not_abort(fmu, tmp_path, machine):
    wrap, reason = MACHINES[machine]
    done = run(wrap([str(OMSIMULATOR), str(fmu), "--stopTime=0.01", "--stepSize=0.001",
                     "--resultFile=r.mat"]), cwd=tmp_path)
    assert done.returncode not in CRASHES, done.stdout[-2000:] + done.stderr[-2000:]
    assert "basic_string" not in done.stderr
    # through OMSimulator's own log, as an fmi2Fatal of category logStatusFatal
    assert "IceImpact/logStatusFatal: " in done.stderr, done.stderr[-3000:]
    assert reason in done.stderr


@pytest.mark.parametrize("machine", MACHINES)
def test_the_c_host_with_a_strict_logger_gets_the_reason(c_host, fmu_dir, machine):
    wrap, reason = MACHINES[machine]
    done = run(wrap([str(c_host), fmu_dir, "-n", "3", "-S", "-N"]))
    assert done.returncode == 3, done.stderr[-3000:]
    assert reason in done.stderr
    assert "null-after-failure fmi2SetupExperiment 3" in done.stdout


OMS_SCRIPT = """
import sys
from OMSimulator import SSP, CRef
model = SSP()
model.addResource({fmu!r}, new_name="resources/IceImpact.fmu")
model.addComponent(CRef("default", "floe"), "resources/IceImpact.fmu")
m = model.instantiate()
m.setStopTime(0.2)
m.setFixedStepSize(1e-3)
m.initialize()
m.simulate()
print("simulated", flush=True)
# no terminate() nor delete(): OMSimulator's static destructor terminates the instance at exit,
# after this Python is finalized
"""


@pytest.mark.skipif(OMSIMULATOR is None, reason=OMSIMULATOR_ABSENT)
def test_an_omsimulator_script_that_ends_without_terminate_exits_cleanly(fmu, tmp_path):
    pytest.importorskip("lxml")
    package = OMSIMULATOR.parent.parent / "python"
    env = {**os.environ, "PYTHONPATH": str(package)}
    done = run([sys.executable, "-c", textwrap.dedent(OMS_SCRIPT.format(fmu=str(fmu)))],
               cwd=tmp_path, env=env)
    assert "simulated" in done.stdout, done.stdout[-2000:] + done.stderr[-2000:]
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
