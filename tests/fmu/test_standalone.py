"""The standalone IceImpact.fmu (``build_fmu.py --standalone``) on a machine with no Python.

Each native host runs in a private mount namespace that hides every Python installation, venv and
site-packages of this machine, with an empty environment (``native_host.without_python``): the FMU
can only run on the CPython, numpy and scipy it carries. Its results are those of the default FMU
run by FMPy: the C host to the last bit on FMPy's grid, OMSimulator to the last bit against its
own run of the default FMU and against FMPy stepped on its grid, ECOS to its CSV's 6 decimals
against its run of the default FMU. In a Python host (FMPy) the standalone FMU runs on the host's
interpreter instead, and equals the default FMU too.
"""

from __future__ import annotations

import json
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu

import system  # (its reader of OMSimulator's result files)
from fmu_host import DT, OUTPUTS, build_module
from native_host import (
    OMSIMULATOR,
    OMSIMULATOR_ABSENT,
    ecos_binary,
    parse_csv,
    read_ecos_csv,
    run_empty_env,
    without_python,
)

N_STEPS = 2000
VALUES = {"ice.M": 800.0}  # impacts within the first second


def run(command: list[str], cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(command, cwd=cwd, capture_output=True, text=True, timeout=300)


@pytest.fixture(scope="module")
def fmpy_reference(fmu) -> np.ndarray:
    """FMPy's run of the default FMU, N_STEPS steps of DT (communication points k DT)."""
    return simulate_fmu(str(fmu), stop_time=N_STEPS * DT, output_interval=DT,
                        start_values=VALUES)


# What the FMU carries ------------------------------------------------------------------------
def test_the_standalone_fmu_carries_its_runtime_and_declares_no_execution_tool(standalone_fmu,
                                                                              fmu):
    with zipfile.ZipFile(standalone_fmu) as archive:
        names = set(archive.namelist())
        description = archive.read("modelDescription.xml").decode()
        config = json.loads(archive.read("resources/iceimpact_fmu/python.json"))
    home = "binaries/linux64/python/lib/"
    assert f"{home}libpython3.11.so.1.0" in names
    assert f"{home}python3.11/os.py" in names
    assert any(n.startswith(f"{home}python3.11/site-packages/numpy/") for n in names)
    assert any(n.startswith(f"{home}python3.11/site-packages/scipy/integrate/") for n in names)
    assert 'needsExecutionTool="false"' in description
    assert read_model_description(str(standalone_fmu)).coSimulation.needsExecutionTool is False
    assert read_model_description(str(fmu)).coSimulation.needsExecutionTool is True
    # trimmed: no tests, headers, timestamp .pyc, unused scipy subpackages, nor the build's paths
    assert not any("/tests/" in n or n.endswith((".h", ".pyi")) for n in names)
    assert not any(n.startswith(f"{home}python3.11/site-packages/scipy/{sub}/")
                   for n in names for sub in ("io", "stats", "ndimage", "signal"))
    assert config["libpython"] is None and config["prefix"] is None
    assert config["site"] == ["../binaries/linux64/python/lib/python3.11/site-packages"]
    assert not any(n.startswith("binaries/win64/") for n in names)
    assert standalone_fmu.stat().st_size < 90e6


def test_the_standalone_fmu_passes_fmpy_validation(standalone_fmu):
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(standalone_fmu)) == []


# No Python on the machine --------------------------------------------------------------------
def test_the_namespace_has_no_python(c_host, fmu_dir):
    """The premise: there, no python runs and the default FMU finds no libpython."""
    done = run(without_python(["sh", "-c", "python3 -c pass || python3.11 -c pass"]))
    assert done.returncode != 0
    done = run(without_python([str(c_host), fmu_dir, "-n", "3"]))
    assert done.returncode == 3
    assert "needs the shared library of Python" in done.stderr


def test_c_host_without_python_equals_fmpy_on_the_default_fmu(c_host, standalone_dir,
                                                                 fmpy_reference):
    done = run(without_python([str(c_host), standalone_dir, "-n", str(N_STEPS), "-h", str(DT),
                               "-s", "ice.M=800"]))
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stderr == ""  # nothing printed: no warning of a missing module on the way
    got = parse_csv(done.stdout)
    np.testing.assert_array_equal(got["time"], fmpy_reference["time"])
    for o in OUTPUTS:  # %.17g: the same doubles, to the last bit
        np.testing.assert_array_equal(got[o.name], fmpy_reference[o.name], err_msg=o.name)
    assert got["contact.count"][-1] > 0


def test_the_standalone_fmu_ignores_the_hosts_python_environment(c_host, standalone_dir,
                                                                 fmpy_reference, tmp_path):
    """PYTHONHOME/PYTHONPATH of the host's environment, pointing at nonsense, change nothing."""
    (tmp_path / "numpy").mkdir()
    (tmp_path / "numpy" / "__init__.py").write_text("raise ImportError('not this numpy')\n")
    command = without_python(["env", f"PYTHONHOME={tmp_path}", f"PYTHONPATH={tmp_path}",
                              str(c_host), standalone_dir, "-n", "500", "-s", "ice.M=800",
                              "-o", "structure.x"])
    done = run(command)
    assert done.returncode == 0, done.stderr[-3000:]
    np.testing.assert_array_equal(parse_csv(done.stdout)["structure.x"],
                                  fmpy_reference["structure.x"][:501])


def test_failures_of_the_standalone_fmu_are_messages_without_python(c_host, standalone_dir):
    """A refused parameter and every failure path of the C host, with the bundled runtime."""
    done = run(without_python([str(c_host), standalone_dir, "-n", "5", "-s", "structure.m=-1",
                               "-S", "-N"]))
    assert done.returncode == 4, done.stderr[-3000:]  # the host's code for a refused step
    assert "structure.m = -1.0 is not allowed: > 0" in done.stderr
    assert all(line.endswith(" 3") for line in done.stdout.splitlines()
               if line.startswith("null fmi2") and "FreeInstance" not in line)
    done = run(without_python([str(c_host), standalone_dir, "-n", "5", "-E"]))
    assert done.returncode == 0, done.stderr[-3000:]


def test_ecos_without_python_equals_the_default_fmu(standalone_fmu, fmu, tmp_path):
    ecos = ecos_binary(tmp_path)
    results = {}
    for name, path, wrap in (("standalone", standalone_fmu, without_python),
                             ("default", fmu, lambda c: c)):
        folder = tmp_path / name
        folder.mkdir()
        done = run(wrap([str(ecos), "simulate", "--path", str(path), "--stopTime", "2",
                         "--stepSize", str(DT)]), cwd=folder)
        assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
        results[name] = read_ecos_csv(folder / "IceImpact.csv")
    assert set(results["standalone"]) == set(results["default"])
    for column, values in results["default"].items():  # the same 6-decimal text
        np.testing.assert_array_equal(results["standalone"][column], values, err_msg=column)
    assert results["standalone"]["instance::contact.count[INT]"][-1] > 0


@pytest.mark.skipif(OMSIMULATOR is None, reason=OMSIMULATOR_ABSENT)
def test_omsimulator_without_python_equals_its_run_of_the_default_fmu(standalone_fmu, fmu,
                                                                      tmp_path):
    results = {}
    for name, path, wrap in (("standalone", standalone_fmu, without_python),
                             ("default", fmu, lambda c: c)):
        done = run(wrap([str(OMSIMULATOR), str(path), "--stopTime=2", f"--stepSize={DT}",
                         f"--resultFile={name}.mat"]), cwd=tmp_path)
        assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
        assert "error" not in done.stdout.lower(), done.stdout[-2000:]
        results[name] = system.read_mat(tmp_path / f"{name}.mat")
    for o in OUTPUTS:
        np.testing.assert_array_equal(results["standalone"][o.name], results["default"][o.name],
                                      err_msg=o.name)
    assert results["standalone"]["contact.count"][-1] > 0
    # and FMPy on OMSimulator's grid (t += h; each time point is written twice: the last)
    time = results["standalone"]["time"]
    last = np.r_[np.diff(time) != 0, True]
    grid = time[last]
    expected = fmpy_on_grid(fmu, grid)
    for o in OUTPUTS:
        np.testing.assert_array_equal(results["standalone"][o.name][last], expected[o.name],
                                      err_msg=o.name)


def fmpy_on_grid(fmu: Path, grid: np.ndarray) -> dict[str, np.ndarray]:
    """The default FMU stepped by FMPy from each time of ``grid`` to the next."""
    from fmpy import extract
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(fmu))
    refs = {v.name: v.valueReference for v in md.modelVariables}
    slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu)),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName="grid")
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    getters = {float: slave.getReal, int: slave.getInteger, bool: slave.getBoolean}
    rows = []
    for k in range(len(grid)):
        if k:
            slave.doStep(grid[k - 1], grid[k] - grid[k - 1])
        rows.append({o.name: getters[o.kind]([refs[o.name]])[0] for o in OUTPUTS})
    slave.terminate()
    slave.freeInstance()
    return {o.name: np.array([row[o.name] for row in rows], dtype=float) for o in OUTPUTS}


# In a Python host ----------------------------------------------------------------------------
def test_in_fmpy_the_standalone_fmu_runs_on_the_hosts_python(standalone_fmu, fmpy_reference):
    """FMPy's process runs Python already: the loader keeps it (the bundled libpython is never
    loaded), and numpy and scipy are the host's, which it already imported."""
    result = simulate_fmu(str(standalone_fmu), stop_time=N_STEPS * DT, output_interval=DT,
                          start_values=VALUES)
    for o in OUTPUTS:
        np.testing.assert_array_equal(result[o.name], fmpy_reference[o.name], err_msg=o.name)
    with open("/proc/self/maps") as maps:
        mapped = maps.read()
    assert "binaries/linux64/python/lib/libpython" not in mapped


def test_in_a_python_without_numpy_the_bundled_site_packages_serve(standalone_dir):
    """A Python host of the FMU's version whose path has no site-packages (-I -S): the boot
    takes the FMU's own numpy and scipy."""
    resources = Path(standalone_dir) / "resources"
    script = (
        f"import sys, importlib; sys.path.insert(0, {str(resources)!r});"
        "name = open(sys.path[0] + '/slavemodule.txt').read().strip();"
        "importlib.import_module(name).IceImpact; import numpy, scipy;"
        "print(numpy.__file__); print(scipy.__file__)")
    done = run_empty_env([sys.executable, "-I", "-S", "-c", script])
    assert done.returncode == 0, done.stderr[-3000:]
    bundled = str(resources.parent / "binaries/linux64/python/lib/python3.11/site-packages")
    assert all(line.startswith(bundled) for line in done.stdout.split()), done.stdout


# ModalStructure.fmu --------------------------------------------------------------------------
def test_the_standalone_modal_structure_runs_without_python(c_host, tmp_path):
    """ModalStructure.fmu standalone, without Python, equals the default FMU in the same host."""
    from fmpy import extract

    build = build_module()
    default = build.build_modal(tmp_path / "dist")
    standalone = build.make_standalone(default, tmp_path / "standalone", "ModalStructure")
    assert (read_model_description(str(standalone)).coSimulation.needsExecutionTool is False)
    runs = {}
    for name, fmu, wrap in (("standalone", standalone, without_python),
                            ("default", default, lambda c: ["env", "-i", *c])):
        folder = extract(str(fmu), unzipdir=str(tmp_path / f"{name}_x"))
        done = run(wrap([str(c_host), folder, "-n", "500", "-s", "force=1000"]))
        assert done.returncode == 0, done.stderr[-3000:]
        runs[name] = done.stdout
    assert runs["standalone"] == runs["default"]  # %.17g: to the last bit
    assert parse_csv(runs["standalone"])["x"][-1] > 0


def test_a_preload_entry_that_is_a_path_is_refused(c_host, standalone_dir, tmp_path):
    """The loader loads the libraries named in lib/preload.list from lib/ only: an entry that
    is a path (one that would reach outside the FMU) is refused with a message, not loaded."""
    import shutil

    copy = tmp_path / "fmu"
    shutil.copytree(standalone_dir, copy)
    preload = copy / "binaries" / "linux64" / "python" / "lib" / "preload.list"
    preload.write_text("../../../../../../lib/x86_64-linux-gnu/libz.so.1\n")
    done = run_empty_env([str(c_host), str(copy), "-n", "1"])
    assert done.returncode == 3, done.stderr[-2000:]
    assert "refuses the entry '../../../../../../lib/x86_64-linux-gnu/libz.so.1'" in done.stderr
    assert "a library name, not a path" in done.stderr
