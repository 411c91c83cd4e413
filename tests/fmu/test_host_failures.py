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

Each failure path is run for both FMUs (the ``fmi`` fixture: IceImpact.fmu in host.c, and the
FMI 3.0 IceImpact3.fmu in its port ``tests/c_host/host3.c``, whose -N calls every FMI 3.0
function that takes an instance): the FMI 3.0 FMU runs the same slave behind the same loader and
must end each path the same way, with fmi3 statuses of the same values; refused steps and bad
parameters give the same messages and statuses in both. The OMSimulator build beside the
repository runs FMI 3.0 FMUs too: it runs IceImpact3.fmu as IceImpact.fmu, to the bit.
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
from dataclasses import dataclass
from pathlib import Path

import numpy as np
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

FMI_DISCARD, FMI_ERROR = 2, 3
CRASHES = (-6, -11, 134, 139)  # SIGABRT, SIGSEGV, as a return code or through a shell


def run(command: list[str], cwd: Path | None = None,
        env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(command, cwd=cwd, capture_output=True, text=True, timeout=300, env=env)


def null_statuses(stdout: str, prefix: str = "null ") -> dict[str, int]:
    return {line.split()[1]: int(line.split()[2]) for line in stdout.splitlines()
            if line.startswith(prefix) and "FreeInstance" not in line}


@dataclass(frozen=True)
class Fmi:
    """One FMI version's FMU and C host, and the names a failure path shows in it."""

    version: str  # "2" or "3"
    host: Path  # the C host: tests/c_host/host.c or host3.c, compiled
    folder: str  # the extracted FMU
    fmu: Path
    name: str  # the FMU's file name, as its messages begin
    null_calls: int  # the C host's -N calls, the free aside (FMI 3.0: all 70 of the standard)
    after_failure: str  # what the C host -N (and ECOS) call on the NULL instance next
    failed_start: str  # the loader's line on the C host's failed start (a regular expression)
    oms_fatal: str  # how OMSimulator shows an fmiXFatal of category logStatusFatal


@pytest.fixture(scope="module", params=["2", "3"], ids=["fmi2", "fmi3"])
def fmi(request) -> Fmi:
    value = request.getfixturevalue
    if request.param == "2":
        return Fmi("2", value("c_host"), value("fmu_dir"), value("fmu"), "IceImpact.fmu", 13,
                   "fmi2SetupExperiment", r"fmi2Instantiate of instance 'host' failed",
                   "IceImpact/logStatusFatal: ")
    # the instantiation the loader names is its own (FMI 2.0) one, inside fmi3.c
    return Fmi("3", value("c_host3"), value("fmu3_dir"), value("fmu3"), "IceImpact3.fmu", 70,
               "fmi3EnterInitializationMode",
               r"fmi\dInstantiate\w* of instance 'host' failed", "[fmi3Fatal] logStatusFatal: ")


def test_every_call_on_a_null_instance_is_an_error_and_the_run_goes_on(fmi):
    done = run_empty_env([str(fmi.host), fmi.folder, "-n", "5", "-N", "-o", "structure.x"])
    assert done.returncode == 0, done.stderr[-3000:]
    statuses = null_statuses(done.stdout)
    assert len(statuses) == fmi.null_calls and set(statuses.values()) == {FMI_ERROR}, statuses
    assert f"null fmi{fmi.version}FreeInstance done" in done.stdout
    # said once on stderr, not once a call
    assert done.stderr.count("was called with a NULL instance") <= 2, done.stderr
    rows = done.stdout.split(f"null fmi{fmi.version}FreeInstance done\n")[1]
    assert len(parse_csv(rows)["time"]) == 6


def test_without_numpy_the_reason_reaches_stderr_and_a_strict_logger(fmi):
    """PythonFMU logs the failed start with a NULL category: a logger that aborts on NULL (as
    OMSimulator's does) gets logStatusFatal instead; then a call on the NULL instance
    (fmi2SetupExperiment, fmi3EnterInitializationMode)."""
    done = run(without_numpy([str(fmi.host), fmi.folder, "-n", "3", "-S", "-N"]))
    assert done.returncode == 3, done.stderr[-3000:]
    assert "cannot import numpy" in done.stderr
    assert "apt-get install python3-numpy python3-scipy" in done.stderr  # PEP 668 systems
    assert "[logStatusFatal]" in done.stderr
    assert re.search(fmi.failed_start, done.stderr), done.stderr[-3000:]
    assert f"null-after-failure {fmi.after_failure} 3" in done.stdout


def test_a_host_that_exits_without_terminating_exits_cleanly(fmi):
    done = run_empty_env([str(fmi.host), fmi.folder, "-n", "200", "-s", "ice.M=800", "-E"])
    assert done.returncode == 0, done.stderr[-3000:]


def test_a_host_exits_cleanly_every_time(fmi):
    """Python's finalization at exit frees through scipy's extension modules: PythonFMU's exit
    guard (iceimpact.fmi.pythonfmu_fixes.guard_native_exit, registered by the slave after its
    imports) must run before their static destructors, for the FMI 2.0 and FMI 3.0 libraries
    alike; else a run can end in SIGSEGV after its last row."""
    for _ in range(3):
        done = run_empty_env([str(fmi.host), fmi.folder, "-n", "20", "-o", "structure.x"])
        assert done.returncode == 0, done.stderr[-3000:]


def test_refused_steps_and_bad_parameters_say_the_same_in_both_versions(c_host, fmu_dir,
                                                                        c_host3, fmu3_dir):
    """The same messages and statuses: fmi2Discard / fmi3Discard for a step the FMU refuses
    (more impacts than solver.max_impacts), fmi2Error / fmi3Error at fmi2DoStep / fmi3DoStep
    after a bad parameter; the outputs printed before each are the same too."""
    for case, status, says in (
            (["-n", "1", "-h", "30", "-s", "solver.max_impacts=3"], FMI_DISCARD,
             "the step needs more than solver.max_impacts = 3 impacts"),
            (["-n", "5", "-s", "structure.m=-1"], FMI_ERROR,
             "doStep refused: exitInitializationMode: structure.m = -1.0 is not allowed: > 0")):
        runs = [run_empty_env([str(host), folder, *case])
                for host, folder in ((c_host, fmu_dir), (c_host3, fmu3_dir))]
        for version, done in zip("23", runs, strict=True):
            assert done.returncode == 4, done.stderr[-3000:]  # the host's code for a refused step
            assert f"host: fmi{version}DoStep at t = 0 returned {status}" in done.stderr
        assert runs[0].stdout == runs[1].stdout
        messages = [re.sub(r"fmi[23]", "fmiX", "\n".join(
            line for line in done.stderr.splitlines() if line.startswith("[host]")))
            for done in runs]
        assert messages[0] == messages[1]
        assert says in messages[1], messages[1]


@pytest.mark.skipif(not sysconfig.get_config_var("Py_ENABLE_SHARED"),
                    reason="this Python has no shared libpython for the C host to embed")
def test_calls_after_the_hosts_python_was_finalized_touch_nothing(fmi):
    library = Path(sysconfig.get_config_var("LIBDIR")) / sysconfig.get_config_var("INSTSONAME")
    env = {"PYTHONHOME": sys.base_prefix} if sys.base_prefix != sys.prefix else {}
    done = run([str(fmi.host), fmi.folder, "-n", "1000", "-s", "ice.M=800", "-P", str(library),
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
def test_ecos_prints_the_reason_and_does_not_crash(fmi, tmp_path, machine):
    wrap, reason = MACHINES[machine]
    ecos = ecos_binary(tmp_path)
    done = run(wrap([str(ecos), "simulate", "--path", str(fmi.fmu), "--stopTime", "0.01",
                     "--stepSize", "0.001"]), cwd=tmp_path)
    assert done.returncode not in CRASHES, done.stderr[-3000:]
    assert reason in done.stderr  # ECOS shows FMU logs only with -l debug: the loader's stderr
    assert f"{fmi.after_failure} was called with a NULL instance" in done.stderr


@pytest.mark.skipif(OMSIMULATOR is None, reason=OMSIMULATOR_ABSENT)
@pytest.mark.parametrize("machine", MACHINES)
def test_omsimulator_shows_the_reason_and_does_not_abort(fmi, tmp_path, machine):
    wrap, reason = MACHINES[machine]
    done = run(wrap([str(OMSIMULATOR), str(fmi.fmu), "--stopTime=0.01", "--stepSize=0.001",
                     "--resultFile=r.mat"]), cwd=tmp_path)
    assert done.returncode not in CRASHES, done.stdout[-2000:] + done.stderr[-2000:]
    assert "basic_string" not in done.stderr
    # through OMSimulator's own log, as an fmiXFatal of category logStatusFatal
    assert fmi.oms_fatal in done.stderr, done.stderr[-3000:]
    assert reason in done.stderr


@pytest.mark.skipif(OMSIMULATOR is None, reason=OMSIMULATOR_ABSENT)
def test_omsimulator_runs_the_fmi3_fmu_as_the_fmi2_one(fmu, fmu3, tmp_path):
    """This OMSimulator build does not refuse FMI 3.0 (no "Unsupported FMI version: 3"): it runs
    IceImpact3.fmu with an empty environment, to the bit as its run of IceImpact.fmu."""
    import system  # (its reader of OMSimulator's result files)

    results = {}
    for name, path in (("fmi2", fmu), ("fmi3", fmu3)):
        done = run_empty_env([str(OMSIMULATOR), str(path), "--stopTime=1", "--stepSize=0.001",
                              f"--resultFile={name}.mat"], cwd=tmp_path)
        assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
        assert "error" not in (done.stdout + done.stderr).lower(), done.stdout[-2000:]
        results[name] = system.read_mat(tmp_path / f"{name}.mat")
    assert set(results["fmi3"]) == set(results["fmi2"])
    for column, values in results["fmi2"].items():
        np.testing.assert_array_equal(results["fmi3"][column], values, err_msg=column)
    assert results["fmi3"]["contact.count"][-1] > 0


@pytest.mark.parametrize("machine", MACHINES)
def test_the_c_host_with_a_strict_logger_gets_the_reason(fmi, machine):
    wrap, reason = MACHINES[machine]
    done = run(wrap([str(fmi.host), fmi.folder, "-n", "3", "-S", "-N"]))
    assert done.returncode == 3, done.stderr[-3000:]
    assert reason in done.stderr
    assert f"null-after-failure {fmi.after_failure} 3" in done.stdout


OMS_SCRIPT = """
import sys
from OMSimulator import SSP, CRef
model = SSP()
model.addResource({fmu!r}, new_name="resources/{name}")
model.addComponent(CRef("default", "floe"), "resources/{name}")
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
def test_an_omsimulator_script_that_ends_without_terminate_exits_cleanly(fmi, tmp_path):
    pytest.importorskip("lxml")
    package = OMSIMULATOR.parent.parent / "python"
    env = {**os.environ, "PYTHONPATH": str(package)}
    script = textwrap.dedent(OMS_SCRIPT.format(fmu=str(fmi.fmu), name=fmi.name))
    done = run([sys.executable, "-c", script], cwd=tmp_path, env=env)
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
def partial_fmus(fmi, tmp_path_factory) -> dict[str, Path]:
    """A copy of the FMU per machine of PARTIAL whose python.json records that machine's
    site-packages folder (this Python's own site-packages are hidden when it runs)."""
    copies = {}
    for machine, (packages, _) in PARTIAL.items():
        folder = tmp_path_factory.mktemp(re.sub(r"\W+", "_", machine))
        site = partial_site(folder / "site-packages", **packages)
        copy = folder / "IceImpact"
        shutil.copytree(fmi.folder, copy)
        config_file = copy / "resources" / "iceimpact_fmu" / "python.json"
        config = json.loads(config_file.read_text())
        config["site"] = [str(site)]
        config_file.write_text(json.dumps(config, indent=2))
        copies[machine] = copy
    return copies


@pytest.mark.parametrize("machine", PARTIAL)
def test_a_python_with_part_of_the_requirements_names_what_is_missing(fmi, partial_fmus,
                                                                      machine):
    _, says = PARTIAL[machine]
    for _ in range(3):  # the exit-time corruption was intermittent without valgrind
        done = run(without_numpy([str(fmi.host), str(partial_fmus[machine]), "-n", "3", "-S"]))
        assert done.returncode == 3, done.stderr[-3000:]
        assert f"{fmi.name} needs numpy>=1.24, scipy>=1.10 in the Python" in done.stderr
        for text in says:
            assert text in done.stderr, (text, done.stderr[-3000:])
        assert re.search(fmi.failed_start, done.stderr)
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
def test_a_failed_start_has_no_invalid_access_under_valgrind(fmi, partial_fmus, machine):
    """The C host that gets NULL from fmi2Instantiate and exits: under valgrind, no invalid
    read, write or free, in the failed start or at exit, where PythonFMU's static destructor
    freed the interpreter state that its library destructor then used (valgrind: "Invalid read
    of size 4 in finalizePythonInterpreter", a block allocated in pythonfmu::createInstance and
    freed by an exit handler), which corrupted the heap: "free(): corrupted unsorted chunks"."""
    if machine in PARTIAL:
        wrap, folder, says = without_numpy, str(partial_fmus[machine]), PARTIAL[machine][1]
    else:
        wrap, reason = MACHINES[machine]
        folder, says = fmi.folder, [reason]
    command = [VALGRIND, "--error-exitcode=99", "--trace-children=no",
               f"--suppressions={C_HOST / 'valgrind.supp'}", str(fmi.host), folder, "-n", "3",
               "-S"]
    done = run(wrap(command))
    assert done.returncode == 3, done.stderr[-4000:]  # the host's status, not valgrind's 99
    assert re.search(r"ERROR SUMMARY: 0 errors from 0 contexts", done.stderr), done.stderr[-4000:]
    for kind in ("Invalid read", "Invalid write", "Invalid free", "Mismatched free"):
        assert kind not in done.stderr, done.stderr[-4000:]
    for text in says:
        assert text in done.stderr, (text, done.stderr[-3000:])
