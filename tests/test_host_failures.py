"""Every host's failure path ends in a message and a status, never a crash (fmu_native/loader.c).

Each failure is made by a host that does exactly what a real one does: the C host of
``tests/c_host/host.c`` on request (``-N``: every call on a NULL instance, as ECOS calls
fmi2SetupExperiment on the NULL a failed fmi2Instantiate returned; ``-S``: a logger that aborts
on a NULL category or instance name, as OMSimulator's does; ``-E``: exit without terminating;
``-P``: an embedded Python finalized before fmi2Terminate, as OMSimulator's static destructor
does at the exit of a Python script), then ECOS and OMSimulator themselves. "No numpy" is this
machine with every site-packages hidden (``native_host.without_numpy``); a Python with some of
the requirements (numpy without scipy, scipy or numpy older than requirements.txt allows) is that
machine with the FMU's recorded site-packages folder holding only those
(``native_host.partial_site``). Every failed start is also run under valgrind: no invalid read,
write or free, at exit either (PythonFMU's exit-time use-after-free, which the loader guards
against since the slave's own guard never runs when the start fails).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import textwrap
from pathlib import Path

import pytest

from native_host import (
    C_HOST,
    OMSIMULATOR,
    OMSIMULATOR_ABSENT,
    ecos_binary,
    parse_csv,
    partial_site,
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


# A Python with some of the requirements, and valgrind on every failed start -----------------------
#: Machines whose Python has part of requirements.txt (numpy>=1.24, scipy>=1.10): the packages of
#: its site-packages (``partial_site``: "real" is this Python's own, a version a stand-in of that
#: version) and what the message must say.
PARTIAL = {
    "numpy without scipy": ({"numpy": "real", "scipy": None},
                            ["cannot import scipy (ModuleNotFoundError"]),
    "scipy too old": ({"numpy": "real", "scipy": "1.9.3"},
                      ["scipy 1.9.3 (in ", "is too old: the FMU needs scipy>=1.10"]),
    "numpy too old": ({"numpy": "1.23.5", "scipy": "1.11.4"},
                      ["numpy 1.23.5 (in ", "is too old: the FMU needs numpy>=1.24"]),
}


@pytest.fixture(scope="module")
def partial_fmus(fmu_dir, tmp_path_factory) -> dict[str, Path]:
    """A copy of the FMU per machine of PARTIAL whose python.json records that machine's
    site-packages folder (this Python's own site-packages are hidden when it runs)."""
    copies = {}
    for machine, (packages, _) in PARTIAL.items():
        folder = tmp_path_factory.mktemp(re.sub(r"\W+", "_", machine))
        site = partial_site(folder / "site-packages", **packages)
        copy = folder / "IceImpact"
        shutil.copytree(fmu_dir, copy)
        config_file = copy / "resources" / "iceimpact_fmu" / "python.json"
        config = json.loads(config_file.read_text())
        config["site"] = [str(site)]
        config_file.write_text(json.dumps(config, indent=2))
        copies[machine] = copy
    return copies


@pytest.mark.parametrize("machine", PARTIAL)
def test_a_python_with_part_of_the_requirements_names_what_is_missing(c_host, partial_fmus,
                                                                      machine):
    _, says = PARTIAL[machine]
    for _ in range(3):  # the exit-time corruption was intermittent without valgrind
        done = run(without_numpy([str(c_host), str(partial_fmus[machine]), "-n", "3", "-S"]))
        assert done.returncode == 3, done.stderr[-3000:]
        assert "IceImpact.fmu needs numpy>=1.24, scipy>=1.10 in the Python" in done.stderr
        for text in says:
            assert text in done.stderr, (text, done.stderr[-3000:])
        assert "fmi2Instantiate of instance 'host' failed" in done.stderr
    if PARTIAL[machine][0]["scipy"] is None:
        # no Python has both: the loader says which it found and what their site-packages hold
        site = partial_fmus[machine].parent / "site-packages"
        assert ("looked for a Python 3.11, 3.12 or 3.13 whose site-packages hold numpy and "
                "scipy, found none") in done.stderr
        assert f"{site} (numpy)" in done.stderr, done.stderr[-3000:]


VALGRIND = shutil.which("valgrind")
VALGRIND_ABSENT = ("valgrind is not installed (scripts/system-deps.sh installs it: apt-get "
                   "install valgrind)")
#: The host's failed starts: the five machines, each wrapped as the tests above run it.
FAILED_STARTS = ["no Python", "Python without numpy", *PARTIAL]


@pytest.mark.skipif(VALGRIND is None, reason=VALGRIND_ABSENT)
@pytest.mark.parametrize("machine", FAILED_STARTS)
def test_a_failed_start_has_no_invalid_access_under_valgrind(c_host, fmu_dir, partial_fmus,
                                                             machine):
    """The C host that gets NULL from fmi2Instantiate and exits: under valgrind, no invalid
    read, write or free, in the failed start or at exit, where PythonFMU's static destructor
    freed the interpreter state that its library destructor then used (valgrind: "Invalid read
    of size 4 in finalizePythonInterpreter", a block allocated in pythonfmu::createInstance and
    freed by an exit handler), which corrupted the heap: "free(): corrupted unsorted chunks"."""
    if machine in PARTIAL:
        wrap, folder, says = without_numpy, str(partial_fmus[machine]), PARTIAL[machine][1]
    else:
        wrap, reason = MACHINES[machine]
        folder, says = fmu_dir, [reason]
    command = [VALGRIND, "--error-exitcode=99", "--trace-children=no",
               f"--suppressions={C_HOST / 'valgrind.supp'}", str(c_host), folder, "-n", "3", "-S"]
    done = run(wrap(command))
    assert done.returncode == 3, done.stderr[-4000:]  # the host's status, not valgrind's 99
    assert re.search(r"ERROR SUMMARY: 0 errors from 0 contexts", done.stderr), done.stderr[-4000:]
    for kind in ("Invalid read", "Invalid write", "Invalid free", "Mismatched free"):
        assert kind not in done.stderr, done.stderr[-4000:]
    for text in says:
        assert text in done.stderr, (text, done.stderr[-3000:])
