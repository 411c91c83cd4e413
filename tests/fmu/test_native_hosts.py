"""IceImpact.fmu in native FMI hosts started with an empty environment, and in one shared process.

Native hosts (a plain C master, the ECOS command line, libcosim's C API) run with ``env={}``:
no LD_PRELOAD, PYTHONPATH or PYTHONHOME. The FMU's loader (fmu_native/loader.c) brings in the
libpython it was built with and the boot module (fmu_src/iceimpact_fmu_boot.py) the Python
environment recorded in resources/ (see docs/how-to/hand-over-the-fmu.md). Also here: the FMU
runs its own core whatever the host imported, errors reach a default host call, instances do not
leak, and several FMUs share a process; with Python 3.12 and 3.13 (FMPy under each, and a C host
on a machine whose only Python is one of them) the results equal Python 3.11's to the last bit.

The FMI 3.0 IceImpact3.fmu runs the same slave behind the same loader (fmu_native/fmi3.c): in the
C host's FMI 3.0 port (tests/c_host/host3.c), in ECOS, with Python 3.12 and 3.13, and standalone
on a machine with no Python, its outputs equal IceImpact.fmu's in the same host, to the printed
digit; host3.c's early return (-R) prints a row at each contact event, as the core steps them.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.fmi1 import FMICallException

from fmu_host import (
    DT,
    FMI_ERROR,
    OUTPUTS,
    ROOT,
    Instance,
    build_module,
    columns,
    errors,
    helpers_env,
)
from iceimpact import Scene, Simulator
from native_host import (
    C_HOST,
    compile_c,
    ecos_binary,
    only_python,
    other_python,
    parse_csv,
    python_facts,
    run_empty_env,
    venv_for,
    without_python,
)

VALUES = {"ice.M": 800.0}  # impacts within the first second
N_STEPS = 2000


def core(values: dict, n: int, step) -> dict[str, np.ndarray]:
    """The core stepped n times with ``step(k)`` seconds: outputs after every step."""
    scene = Scene.from_fmi(values)
    sim = Simulator(scene)
    reports = [sim.advance(step(k), scene.flow_u) for k in range(n)]
    return {o.name: np.array([getattr(r, o.field) for r in reports]) for o in OUTPUTS}


# 1. Loading with an empty environment ------------------------------------------------------------
def test_c_host_with_an_empty_environment_equals_fmpy_every_time(fmu, fmu_dir, c_host):
    args = [str(c_host), fmu_dir, "-n", str(N_STEPS), "-h", str(DT), "-s", "ice.M=800"]
    runs = [run_empty_env(args) for _ in range(5)]
    assert [r.returncode for r in runs] == [0] * 5, runs[-1].stderr
    expected = simulate_fmu(str(fmu), stop_time=N_STEPS * DT, output_interval=DT,
                            start_values=VALUES)
    for done in runs:
        got = parse_csv(done.stdout)
        np.testing.assert_array_equal(got["time"], expected["time"])
        for o in OUTPUTS:  # %.17g: the same doubles, to the last bit
            np.testing.assert_array_equal(got[o.name], expected[o.name], err_msg=o.name)
        assert "undefined symbol" not in done.stderr
    assert got["contact.count"][-1] > 0


def test_c_host3_with_an_empty_environment_equals_the_fmi2_fmu_every_time(fmu3_dir, c_host3,
                                                                         c_host_run_here):
    """IceImpact3.fmu in host3.c prints, byte for byte, what IceImpact.fmu prints in host.c on
    the same grid (every output, %.17g)."""
    args = [str(c_host3), fmu3_dir, "-n", str(N_STEPS), "-s", "ice.M=800"]
    for _ in range(3):
        done = run_empty_env(args)
        assert done.returncode == 0, done.stderr[-3000:]
        assert done.stdout == c_host_run_here.stdout
        assert "undefined symbol" not in done.stderr
        assert "started Python 3.11 (" in done.stderr


def ecos_columns(fmu: Path, folder: Path) -> dict[str, list[str]]:
    """ECOS's command line run of ``fmu`` with an empty environment, 2 s of DT steps: the
    columns of its CSV, as text."""
    ecos = ecos_binary(folder)
    done = run_empty_env([str(ecos), "simulate", "--path", str(fmu), "--stopTime", "2",
                          "--stepSize", str(DT)], cwd=folder)
    assert done.returncode == 0, done.stdout + done.stderr
    (csv,) = folder.glob("*.csv")  # named after the model identifier
    lines = csv.read_text().strip().splitlines()
    header = [h.strip() for h in lines[0].split(",")]
    rows = [[x.strip() for x in line.split(",")] for line in lines[1:]]
    assert all(len(row) == len(header) for row in rows)
    return {name: [row[i] for row in rows] for i, name in enumerate(header)}


@pytest.fixture(scope="module")
def ecos_fmi2(fmu, tmp_path_factory) -> dict[str, list[str]]:
    return ecos_columns(fmu, tmp_path_factory.mktemp("ecos_fmi2"))


def test_ecos_command_line_with_an_empty_environment_equals_the_core(ecos_fmi2):
    assert len(ecos_fmi2["time"]) == N_STEPS + 1
    expected = core({}, N_STEPS, lambda k: DT)  # ECOS steps exactly DT
    for o in OUTPUTS:
        kind = {float: "REAL", int: "INT", bool: "BOOL"}[o.kind]
        got = np.array(ecos_fmi2[f"instance::{o.name}[{kind}]"][1:], dtype=float)
        # ECOS writes its CSV with 6 decimals: equal to the last printed digit
        np.testing.assert_allclose(got, expected[o.name], rtol=0, atol=5.01e-7, err_msg=o.name)
    assert float(ecos_fmi2["instance::contact.count[INT]"][-1]) > 0


def test_ecos_command_line_runs_the_fmi3_fmu_as_the_fmi2_one(fmu3, ecos_fmi2, tmp_path):
    """ECOS, an FMI 3.0 master too, with an empty environment: every column of its CSV the same
    text for IceImpact3.fmu as for IceImpact.fmu (ECOS prints 6 decimals)."""
    got = ecos_columns(fmu3, tmp_path)
    # FMI 3.0's independent variable, a variable of the FMU: ECOS records it as a column
    time = np.array(got.pop("instance::time[REAL]"), dtype=float)
    np.testing.assert_allclose(time, np.array(got["time"], dtype=float), rtol=0, atol=5e-7)
    assert set(got) == set(ecos_fmi2)
    for column, text in ecos_fmi2.items():
        assert got[column] == text, column
    assert float(got["instance::contact.count[INT]"][-1]) > 0


@pytest.fixture(scope="module")
def cosim_host(tmp_path_factory) -> Path:
    libcosimpy = pytest.importorskip("libcosimpy")
    libdir = Path(libcosimpy.__file__).parent / "libcosimc"
    return compile_c(C_HOST / "cosim_host.c", tmp_path_factory.mktemp("cosim") / "cosim_host",
                     f"-L{libdir}", "-lcosimc", f"-Wl,-rpath,{libdir}")


def run_cosim(cosim_host: Path, fmu: Path, md, n: int, sets: dict) -> subprocess.CompletedProcess:
    variables = {v.name: v for v in md.modelVariables}
    groups = [[o for o in OUTPUTS if o.kind is kind] for kind in (float, int, bool)]
    lists = [",".join(str(variables[o.name].valueReference) for o in g) or "-" for g in groups]
    initial = [f"{'i' if variables[k].type == 'Integer' else 'r'}:"
               f"{variables[k].valueReference}={v!r}" for k, v in sets.items()]
    return run_empty_env([str(cosim_host), str(fmu), str(n), str(round(DT * 1e9)), *lists,
                          *initial])


def test_libcosim_with_an_empty_environment_equals_the_core(fmu, model_description, cosim_host):
    done = run_cosim(cosim_host, fmu, model_description, N_STEPS, VALUES)
    assert done.returncode == 0, done.stderr[-3000:]
    data = np.loadtxt(done.stdout.splitlines(), delimiter=",", ndmin=2)
    names = [o.name for kind in (float, int, bool) for o in OUTPUTS if o.kind is kind]
    # libcosim keeps time in nanoseconds: step k is (k+1)*1e6/1e9 - k*1e6/1e9 seconds
    ns = round(DT * 1e9)
    expected = core(VALUES, N_STEPS, lambda k: (k + 1) * ns / 1e9 - k * ns / 1e9)
    for i, name in enumerate(names, start=1):
        np.testing.assert_array_equal(data[:, i], expected[name].astype(float), err_msg=name)
    assert expected["contact.count"][-1] > 0


# What a machine must provide is named at load time ------------------------------------------------
@pytest.fixture
def fmu_copy(fmu_dir, tmp_path) -> Path:
    copy = tmp_path / "IceImpact"
    shutil.copytree(fmu_dir, copy)
    return copy


def edit_python_json(fmu_copy: Path, **changes) -> None:
    path = fmu_copy / "resources" / "iceimpact_fmu" / "python.json"
    config = json.loads(path.read_text())
    config.update(changes)
    path.write_text(json.dumps(config))


def test_recorded_environment_supplies_what_the_base_python_lacks(fmu_copy, c_host):
    """fmpy is installed in the build's environment only (not in the base Python that an
    embedded interpreter starts with): required, it is found through python.json."""
    config = json.loads((fmu_copy / "resources" / "iceimpact_fmu" / "python.json").read_text())
    edit_python_json(fmu_copy, requirements=[*config["requirements"], "fmpy"])
    done = run_empty_env([str(c_host), str(fmu_copy), "-n", "3"])
    assert done.returncode == 0, done.stderr
    edit_python_json(fmu_copy, site=["/nonexistent/site-packages"])
    done = run_empty_env([str(c_host), str(fmu_copy), "-n", "3"])
    assert done.returncode == 3
    assert "IceImpact.fmu needs numpy>=1.24, scipy>=1.10, fmpy" in done.stderr
    assert "cannot import fmpy" in done.stderr
    assert "the environment recorded when the FMU was built is not on this machine" in done.stderr
    assert "-m pip install -r" in done.stderr and "requirements.txt" in done.stderr


def test_missing_libpython_is_named_not_an_undefined_symbol(fmu_copy, c_host, tmp_path):
    build = build_module()
    loader = fmu_copy / "binaries" / "linux64" / "IceImpact.so"
    # the build's version only: this machine has the other versions' libraries elsewhere
    build.compile_loader(loader, Path("/nonexistent/libpython3.11.so.1.0"),
                         "libpython3.11-absent.so.1.0", versions=(build.python_version(),))
    done = run_empty_env([str(c_host), str(fmu_copy), "-n", "3"])
    assert done.returncode == 3
    assert "needs the shared library of Python" in done.stderr
    assert "/nonexistent/libpython3.11.so.1.0: cannot open" in done.stderr
    assert "libpython3.11-absent.so.1.0" in done.stderr and "standalone FMU" in done.stderr
    assert "undefined symbol" not in done.stderr


def test_the_missing_libpython_message_names_every_version_looked_for(fmu_copy, c_host):
    loader = fmu_copy / "binaries" / "linux64" / "IceImpact.so"
    build_module().compile_loader(loader, Path("/nonexistent/libpython3.11.so.1.0"),
                                  "libpython3.11-absent.so.1.0", versions=("3.11", "3.98", "3.99"))
    done = run_empty_env([str(c_host), str(fmu_copy), "-n", "3"])
    assert done.returncode == 3
    assert "needs the shared library of Python 3.11, 3.98 or 3.99" in done.stderr
    for soname in ("libpython3.11-absent.so.1.0", "libpython3.98.so.1.0", "libpython3.99.so.1.0"):
        assert f"{soname}: cannot open shared object file" in done.stderr, soname


# 3. Its own core, whatever the host imported ------------------------------------------------------
def test_fmu_runs_its_own_core_beside_another_iceimpact(fmu_dir, tmp_path):
    """A host that imported other modules named iceimpact and IceImpact: the FMU ignores them."""
    fake = tmp_path / "fake"
    (fake / "iceimpact").mkdir(parents=True)
    (fake / "iceimpact" / "__init__.py").write_text("Scene = Simulator = None\n")
    script = textwrap.dedent(f"""
        import json, sys, types
        sys.path.insert(0, {str(fake)!r})
        import iceimpact
        sys.modules["IceImpact"] = types.ModuleType("IceImpact")
        from fmpy import simulate_fmu
        result = simulate_fmu({str(fmu_dir)!r}, stop_time=1.0, output_interval={DT!r},
                              start_values={VALUES!r})
        assert sys.modules["iceimpact"] is iceimpact and iceimpact.Scene is None
        slave = [m for n, m in sys.modules.items() if n.endswith("_slave")][0]
        print(json.dumps({{"x": result["structure.x"].tolist(), "slave": slave.__file__,
                          "core": slave.FmuModel.__module__}}))
    """)
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result["slave"].startswith(str(fmu_dir))
    assert (result["core"].startswith("_iceimpact_")
            and result["core"].endswith(".fmi.adapter"))
    np.testing.assert_array_equal(result["x"][1:], _grid_core(VALUES, 1000)["structure.x"])


def _grid_core(values: dict, n: int) -> dict[str, np.ndarray]:
    return core(values, n, lambda k: (k + 1) * DT - k * DT)


# 4. Errors reach the user of a default call -------------------------------------------------------
def test_default_fmpy_call_shows_the_bad_parameter_and_raises(fmu, capfd):
    with pytest.raises(FMICallException) as failed:
        simulate_fmu(str(fmu), stop_time=1.0, output_interval=DT,
                     start_values={"structure.m": -1.0})
    assert failed.value.status == FMI_ERROR
    out = capfd.readouterr().out
    assert "[ERROR] exitInitializationMode: structure.m = -1.0 is not allowed: > 0" in out
    assert "[ERROR] doStep refused" in out


def test_libcosim_shows_the_bad_parameter_and_stops_cleanly(fmu, model_description, cosim_host):
    done = run_cosim(cosim_host, fmu, model_description, 5, {"structure.m": -1.0})
    assert done.returncode == 3, done.stderr[-3000:]
    assert "[error" in done.stderr
    assert "structure.m = -1.0 is not allowed: > 0" in done.stderr


# 5. No leak per instance --------------------------------------------------------------------------
LEAK_SCRIPT = """
from fmu_host import Instance
from fmpy import read_model_description

def rss_kb():
    with open("/proc/self/status") as fh:
        return int(next(line for line in fh if line.startswith("VmRSS")).split()[1])

md = read_model_description({fmu_dir!r})

def cycle():
    inst = Instance({fmu_dir!r}, md)
    inst.initialize({{"impact.e": 0.5}})
    inst.run(5)
    inst.fmu.terminate()
    inst.free()

for _ in range({warm}):
    cycle()
before = rss_kb()
for _ in range({cycles}):
    cycle()
print(rss_kb() - before)
"""


def test_instances_do_not_leak(fmu_dir):
    """500 instances made, run and freed one after the other grow the process by at most 1 MB
    (2 kB an instance). Measured after 800 cycles: the process grows by some 2.4 MB over its
    first few hundred (allocator arenas and caches filling, once), then by about 0.7 kB a
    cycle (356-360 kB over 500). The filling lasts longer with larger variable tables: with
    one Real parameter more (solver.chatter_fraction, or any) the 500 cycles after the first
    300 grew by 992 kB, those after the first 800 by 360 kB."""
    script = LEAK_SCRIPT.format(fmu_dir=str(fmu_dir), warm=800, cycles=500)
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=300, env=helpers_env())
    assert done.returncode == 0, done.stderr
    growth_kb = int(done.stdout.split()[-1])
    assert growth_kb <= 1024, f"RSS grew by {growth_kb} kB over 500 cycles"


DICT_SCRIPT = """
import sys
from fmu_host import Instance
from fmpy import read_model_description

md = read_model_description({fmu_dir!r})
for _ in range({n}):
    Instance({fmu_dir!r}, md).free()
module = next(m for name, m in sys.modules.items()
              if name.startswith("_iceimpact_") and name.endswith("_fmu"))
namespace = module.__dict__
namespace.clear()  # what the interpreter does to a module still alive at shutdown
print(sys.getrefcount(namespace))
"""


def test_instantiations_leave_the_entry_module_its_dictionary(fmu_dir):
    """PythonFMU drops a reference to the entry module's dictionary at every fmi2Instantiate.

    The entry module gives each back as a bare increment. It used to keep the dictionary in a
    list inside itself, which balanced the count only while the list lived: clearing the
    dictionary (the interpreter does it at shutdown) released the list and with it one reference
    per instantiation too many, freed the dictionary while in use, and the decrements that
    followed corrupted the heap (the full test suite aborted at exit). Run in a child process.
    """
    script = DICT_SCRIPT.format(fmu_dir=str(fmu_dir), n=20)
    done = subprocess.run([sys.executable, "-X", "faulthandler", "-c", script],
                          capture_output=True, text=True, timeout=300, env=helpers_env())
    assert done.returncode == 0, done.stderr[-4000:]
    # this name, the module's and the call's reference at least: still alive, not freed
    assert int(done.stdout.split()[-1]) >= 3, done.stdout


# 6. Several FMUs in one process -------------------------------------------------------------------
@pytest.fixture(scope="module")
def trivial_fmu_dir(tmp_path_factory) -> str:
    from fmpy import extract
    from pythonfmu import FmuBuilder

    dest = tmp_path_factory.mktemp("trivial")
    fmu = FmuBuilder.build_FMU(ROOT / "benchmarks" / "trivial_fmu" / "TrivialSlave.py",
                               dest=dest)
    return extract(str(fmu), unzipdir=str(dest / "TrivialSlave"))


def test_two_copies_and_another_pythonfmu_fmu_stepped_alternately(fmu, fmu_dir, tmp_path,
                                                                  model_description,
                                                                  trivial_fmu_dir):
    from fmpy import extract, read_model_description

    other_dir = extract(str(fmu), unzipdir=str(tmp_path / "second_copy"))
    a_values, b_values = VALUES, {"impact.e": 0.5, "drag.model": 2}
    # the other PythonFMU library is loaded first, so that IceImpact's instantiations guard it
    # against PythonFMU's exit-time use-after-free too (iceimpact.fmi.pythonfmu_fixes)
    trivial = Instance(trivial_fmu_dir, read_model_description(trivial_fmu_dir), "trivial")
    a = Instance(fmu_dir, model_description, "a")
    b = Instance(other_dir, model_description, "b")
    n = 1500
    try:
        a.initialize(a_values)
        b.initialize(b_values)
        trivial.initialize()
        rows_a, rows_b = [], []
        for k in range(n):
            rows_a += a.run(1, k)
            assert trivial.step(k * DT, DT) == 0
            rows_b += b.run(1, k)
    finally:
        for inst in (a, b, trivial):
            inst.free()
    assert not errors(a) and not errors(b)
    for rows, values in ((rows_a, a_values), (rows_b, b_values)):
        got, expected = columns(rows), _grid_core(values, n)
        for o in OUTPUTS:
            np.testing.assert_array_equal(got[o.name], expected[o.name], err_msg=o.name)



def test_fmpy_logs_safely_after_hand_stepped_instances_are_freed(fmu, fmu_dir, tmp_path,
                                                                 trivial_fmu_dir):
    """The sequence that crashed the suite (exit 139 in fmi2DoStep of a later simulate_fmu).

    Two copies of the FMU and the TrivialSlave FMU stepped by hand (fmu_host.Instance), freed and
    collected, then a simulate_fmu whose FMU logs a warning: FMPy's logger proxy is one per
    process, so that warning went to the logger of a collected Instance (see fmu_host). Run in a
    child process, so that a crash fails this test instead of ending pytest. Each Instance also
    keeps its own messages only.
    """
    script = textwrap.dedent(f"""
        import gc, sys
        from fmpy import extract, read_model_description, simulate_fmu
        from fmu_host import DT, Instance, errors

        fmu, fmu_dir, trivial_dir = {str(fmu)!r}, {str(fmu_dir)!r}, {str(trivial_fmu_dir)!r}
        md = read_model_description(fmu)
        other_dir = extract(fmu, unzipdir={str(tmp_path / "second_copy")!r})
        a = Instance(fmu_dir, md, "a")
        b = Instance(other_dir, md, "b")
        trivial = Instance(trivial_dir, read_model_description(trivial_dir), "trivial")
        # the eq. 26 window misses the first impact: warns at t = 0.816 s
        a.initialize({{"solver.method": 2, "solver.detection": 1, "ice.M": 800.0}})
        b.initialize({VALUES!r})
        trivial.initialize()
        for k in range(1000):
            a.run(1, k)
            assert trivial.step(k * DT, DT) == 0
            b.run(1, k)
        for inst in (a, b, trivial):
            inst.free()
        warned = [m for s, _, m in a.messages if s == 1 and "contact.penetration" in m]
        assert len(warned) == 1, a.messages
        assert not b.messages and not trivial.messages and not errors(a), (b.messages,
                                                                            trivial.messages)
        del a, b, trivial, inst
        gc.collect()
        result = simulate_fmu(fmu, stop_time=3.0, output_interval=DT,
                              start_values={{"solver.method": 2, "solver.detection": 1,
                                            "ice.M": 800.0}})
        print("steps", len(result))
    """)
    done = subprocess.run([sys.executable, "-X", "faulthandler", "-c", script],
                          capture_output=True, text=True, timeout=300, env=helpers_env())
    assert done.returncode == 0, done.stderr[-4000:]
    # the warning of the last run, printed by FMPy's default logger
    assert "[WARNING] doStep at t = 0.816" in done.stdout, done.stdout
    assert "steps 3001" in done.stdout


def test_the_loader_is_what_hosts_load(fmu_dir):
    loader = Path(fmu_dir) / "binaries" / "linux64" / "IceImpact.so"
    symbols = subprocess.run(["nm", "-D", "--defined-only", str(loader)], capture_output=True,
                             text=True).stdout if shutil.which("nm") else ""
    if symbols:
        assert "fmi2DoStep" in symbols and "Py_" not in symbols
    assert (Path(fmu_dir) / "binaries" / "linux64" / "pythonfmu" / "IceImpact.so").exists()
    assert os.path.getsize(loader) < 100_000


# 7. Python 3.12 and 3.13 -------------------------------------------------------------------------
#: The Pythons besides the build's (3.11) that the FMU runs with; each test skips, with the reason,
#: where this machine lacks one (pyenv's, or python3.X on the PATH) or pip cannot make its venv.
OTHER_PYTHONS = ("3.12", "3.13")


def pins() -> dict[str, str]:
    """numpy, scipy and fmpy at the versions of this test run: only the Python differs."""
    import fmpy
    import scipy

    return {"numpy": np.__version__, "scipy": scipy.__version__, "fmpy": fmpy.__version__}


FMPY_SCRIPT = """
import json, sys
import numpy
from fmpy import simulate_fmu
result = simulate_fmu({fmu!r}, stop_time={stop!r}, output_interval={dt!r}, start_values={values!r})
print(json.dumps({{"python": "%d.%d" % sys.version_info[:2], "numpy": numpy.__version__,
                  "columns": {{name: result[name].tolist() for name in result.dtype.names}}}}))
"""


@pytest.fixture(scope="module")
def fmpy_run_here(fmu) -> np.ndarray:
    """FMPy's run of the FMU in this Python (the build's, 3.11)."""
    return simulate_fmu(str(fmu), stop_time=N_STEPS * DT, output_interval=DT,
                        start_values=VALUES)


@pytest.mark.parametrize("version", OTHER_PYTHONS)
def test_fmpy_under_python_3_12_and_3_13_equals_the_build_python(fmu, fmpy_run_here, version):
    python = venv_for(version, pins())
    script = FMPY_SCRIPT.format(fmu=str(fmu), stop=N_STEPS * DT, dt=DT, values=VALUES)
    done = subprocess.run([str(python), "-c", script], capture_output=True, text=True,
                          timeout=120, env={k: v for k, v in os.environ.items()
                                            if not k.startswith("PYTHON")})
    assert done.returncode == 0, done.stderr[-3000:]
    got = json.loads(done.stdout.strip().splitlines()[-1])
    assert got["python"] == version and got["numpy"] == np.__version__
    assert set(got["columns"]) == set(fmpy_run_here.dtype.names)
    for name, column in got["columns"].items():  # JSON keeps every double exactly
        np.testing.assert_array_equal(np.array(column, dtype=fmpy_run_here[name].dtype),
                                      fmpy_run_here[name], err_msg=name)
    assert got["columns"]["contact.count"][-1] > 0


@pytest.fixture(scope="module")
def c_host_run_here(fmu_dir, c_host) -> subprocess.CompletedProcess:
    """The C host's run with this machine's Pythons all there: the build's (3.11) is started."""
    done = run_empty_env([str(c_host), fmu_dir, "-n", str(N_STEPS), "-s", "ice.M=800"])
    assert done.returncode == 0, done.stderr[-3000:]
    assert "started Python 3.11 (" in done.stderr
    return done


@pytest.mark.parametrize("others", ["hidden", "without numpy and scipy"])
@pytest.mark.parametrize("version", OTHER_PYTHONS)
def test_c_host_on_a_machine_with_python_3_12_or_3_13_equals_the_build_python(
        fmu_dir, c_host, c_host_run_here, tmp_path, version, others):
    """A machine like Ubuntu 24.04 (3.12) or Debian 13 (3.13): the only Python with numpy and
    scipy is ``version``, its libpython where the system's libraries are; Python 3.11 is either
    absent (hidden) or there without numpy and scipy (its site-packages and the build's venv
    hidden). The loader starts ``version``, whose numpy and scipy run the FMU."""
    done = _run_with_only_python(c_host, fmu_dir, tmp_path, version, others)
    assert done.stdout == c_host_run_here.stdout  # every output, %.17g: to the last bit
    assert parse_csv(done.stdout)["contact.count"][-1] > 0


def _run_with_only_python(host, fmu_dir, tmp_path, version: str, others: str):
    """``host`` on the FMU on a machine whose only Python with numpy and scipy is ``version``
    (the others ``hidden`` or ``without numpy and scipy``); checks it ran with ``version``."""
    base = other_python(version)
    site = python_facts(venv_for(version, pins()))["site"]
    command = [str(host), fmu_dir, "-n", str(N_STEPS), "-s", "ice.M=800"]
    done = subprocess.run(only_python(command, base, Path(site), tmp_path,
                                      others="hidden" if others == "hidden" else "no packages"),
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-3000:]
    assert f"started Python {version} (" in done.stderr, done.stderr[-3000:]
    return done


@pytest.mark.parametrize(("version", "others"), [("3.12", "hidden"),
                                                 ("3.13", "without numpy and scipy")])
def test_c_host3_on_a_machine_with_python_3_12_or_3_13_equals_the_fmi2_fmu(
        fmu3_dir, c_host3, c_host_run_here, tmp_path, version, others):
    """IceImpact3.fmu in host3.c on the machines above (one of each kind): it starts
    ``version``, and prints what IceImpact.fmu prints in host.c with the build's Python."""
    done = _run_with_only_python(c_host3, fmu3_dir, tmp_path, version, others)
    assert done.stdout == c_host_run_here.stdout  # every output, %.17g: to the last bit


# 8. IceImpact3.fmu standalone, and early return in a native host ----------------------------------
def test_c_host3_without_python_runs_the_standalone_fmu3_as_the_default_fmus(
        c_host3, standalone3_dir, c_host_run_here):
    """The standalone IceImpact3.fmu on a machine with no Python (every Python of this one
    hidden, an empty environment): its own CPython, numpy and scipy, and the output of the
    default FMUs (IceImpact.fmu in host.c, to the last bit)."""
    done = subprocess.run(without_python([str(c_host3), standalone3_dir, "-n", str(N_STEPS),
                                          "-s", "ice.M=800"]),
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stderr == ""  # nothing printed: no warning of a missing module on the way
    assert done.stdout == c_host_run_here.stdout


def test_c_host3_with_early_return_prints_a_row_at_each_contact_event(c_host3, fmu3_dir):
    """host3.c -R (earlyReturnAllowed) on a 10 ms grid: a row at each early return, at
    lastSuccessfulTime, then on to the same grid point. The rows are the core's, stepped as the
    host steps the FMU (Simulator.advance_to with stop_at_event, to the master's points), to the
    last bit; each impact (contact.count going up) is an early return at its own time."""
    n, h = 2000, 0.01
    done = run_empty_env([str(c_host3), fmu3_dir, "-n", str(n), "-h", str(h), "-s", "ice.M=800",
                          "-R"])
    assert done.returncode == 0, done.stderr[-3000:]
    got = parse_csv(done.stdout)
    sim = Simulator(Scene.from_fmi(VALUES))
    now, times, reports, early = 0.0, [], [], []
    for k in range(1, n + 1):
        t = k * h
        while True:
            end = now + (t - now)  # the FMU's end: communication point plus step size
            report = sim.advance_to(end, stop_at_event=True)
            reports.append(report)
            early.append(report.t != end)
            times.append(report.t if early[-1] else t)
            if not early[-1]:
                break
            now = report.t
        now = t
    early = np.array(early)
    np.testing.assert_array_equal(got["time"][1:], times)
    for o in OUTPUTS:
        np.testing.assert_array_equal(got[o.name][1:],
                                      [float(getattr(r, o.field)) for r in reports],
                                      err_msg=o.name)
    count = got["contact.count"][1:]
    impacts = np.flatnonzero(np.diff(count, prepend=0) > 0)
    assert len(impacts) == count[-1] >= 5  # one impact a row: none shares a step with another
    assert early[impacts].all()
    np.testing.assert_array_equal(got["contact.t_last"][1:][impacts], got["time"][1:][impacts])
