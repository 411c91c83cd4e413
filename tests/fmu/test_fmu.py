"""IceImpact.fmu through real masters: FMPy, ecospy and a C host.

The FMU is built once per session into a temporary folder. Its outputs must equal the core's
:class:`iceimpact.Simulator` stepped with the same communication steps; bad inputs must give a
non-OK status with a log message naming the variable, the value and the allowed range, and leave
an instance that can still be freed.
"""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.validation import validate_fmu

from fmu_host import (
    DT,
    FMI_DISCARD,
    FMI_ERROR,
    FMI_OK,
    OUTPUTS,
    ROOT,
    Instance,
    assert_outputs_finite,
    columns,
    errors,
)
from iceimpact import Scene, Simulator, run
from iceimpact.contract import FLOW_INPUT, PARAMETERS, markdown_table

# Scenes of the equality tests (FMI names -> values) and their horizons (s).
SCENES = {
    "figure2": ({}, 20.0),
    "quadratic": ({"drag.model": 2}, 20.0),
    "e0.5": ({"impact.e": 0.5}, 20.0),  # sticking from t ~ 10 s
}


# Reference and masters ----------------------------------------------------------------------------
def reference(values: dict, t_end: float, flow=None,
              h_exact: bool = False) -> dict[str, np.ndarray]:
    """The core stepped like a master: communication points k*DT (FMPy), or steps of exactly DT.

    ``flow`` gives the flow speed of each step (array), default the scene's.
    """
    scene = Scene.from_fmi(values)
    sim = Simulator(scene)
    n = round(t_end / DT)
    reports = [sim.report]
    for k in range(n):
        h = DT if h_exact else (k + 1) * DT - k * DT
        u = scene.flow_u if flow is None else float(flow[k])
        reports.append(sim.advance(h, u))
    return {o.name: np.array([getattr(r, o.field) for r in reports]) for o in OUTPUTS}


def assert_outputs_equal(actual, expected: dict[str, np.ndarray], start: int = 0,
                         force_rtol: float = 0.0) -> None:
    """Equal to 1e-12 absolute; ``force_rtol`` for contact.force (and coupling.force) when the
    step sizes differ in their last bits (force = impulse / h magnifies them)."""
    for o in OUTPUTS:
        got = np.asarray(actual[o.name])[start:]
        want = expected[o.name][start:]
        assert got.shape == want.shape, o.name
        if o.kind is float:
            # coupling.force is contact.force with the built-in structure
            rtol = force_rtol if o.name in ("contact.force", "coupling.force") else 0.0
            # structure.force = k x: the displacements' 1e-12 m times the stiffness
            atol = 1e-12 * (Scene().structure_k if o.name == "structure.force" else 1.0)
            np.testing.assert_allclose(got, want, rtol=rtol, atol=atol, err_msg=o.name)
        else:
            np.testing.assert_array_equal(got.astype(o.kind), want.astype(o.kind),
                                          err_msg=o.name)


_fmpy_cache: dict[tuple, np.ndarray] = {}


def fmpy_run(fmu: Path, values: dict, t_end: float) -> np.ndarray:
    key = (str(fmu), tuple(sorted(values.items())), t_end)
    if key not in _fmpy_cache:
        _fmpy_cache[key] = simulate_fmu(str(fmu), start_time=0.0, stop_time=t_end,
                                        output_interval=DT, start_values=values)
    return _fmpy_cache[key]


# Model description --------------------------------------------------------------------------------
def test_validate_fmu_finds_no_problem(fmu):
    assert validate_fmu(str(fmu)) == []


def test_model_description_follows_the_interface(fmu, model_description):
    md = model_description
    variables = {v.name: v for v in md.modelVariables}
    units = {u.name for u in md.unitDefinitions}
    for v in md.modelVariables:
        assert v.description, v.name
        if v.type == "Real":
            assert v.unit in units, v.name
    for spec in PARAMETERS:
        v = variables[spec.name]
        assert v.causality == "parameter"
        assert v.variability == ("tunable" if spec.tunable else "fixed")
        assert v.type == ("Integer" if spec.kind is int else "Real")
        if spec.kind is float:
            assert v.unit == spec.unit
        if spec.minimum is not None:
            assert float(v.min) == spec.minimum
        if spec.maximum is not None:
            assert float(v.max) == spec.maximum
        assert float(v.start) == getattr(Scene(), spec.field)
    flow = variables[FLOW_INPUT.name]
    assert (flow.causality, flow.unit, float(flow.start)) == ("input", "m/s", 0.1)
    outputs = [v for v in md.modelVariables if v.causality == "output"]
    assert [v.name for v in outputs] == [o.name for o in OUTPUTS]
    assert {u.variable.name for u in md.initialUnknowns} == {o.name for o in OUTPUTS}
    for v in outputs:
        assert v.initial == "calculated"
        if v.type in ("Integer", "Boolean"):
            assert v.variability == "discrete"
    assert variables["contact.gap"].min == "0"
    experiment = md.defaultExperiment
    assert (float(experiment.startTime), float(experiment.stopTime),
            float(experiment.stepSize)) == (0.0, 400.0, 1e-3)
    assert md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate


def test_fmu_bundles_the_core_and_its_requirements(fmu):
    with zipfile.ZipFile(fmu) as z:
        names = set(z.namelist())
        requirements = z.read("resources/requirements.txt").decode()
        entry = z.read("resources/slavemodule.txt").decode()
    core = ROOT / "fmu_src" / "iceimpact"
    for path in core.rglob("*.py"):
        assert f"resources/iceimpact/{path.relative_to(core).as_posix()}" in names
    # the slave and its boot module, the private entry module PythonFMU imports (build_fmu.py)
    assert {"resources/iceimpact_fmu/IceImpact.py", "resources/iceimpact_fmu/boot.py",
            "resources/iceimpact_fmu/python.json", f"resources/{entry}.py"} <= names
    assert entry.startswith("_iceimpact_") and "resources/IceImpact.py" not in names
    # the loader and PythonFMU's library behind it
    assert {"binaries/linux64/IceImpact.so", "binaries/linux64/pythonfmu/IceImpact.so"} <= names
    assert not any("__pycache__" in n for n in names)
    assert "numpy" in requirements and "scipy" in requirements


def test_docs_describe_every_variable(model_description):
    """The documentation's page of FMU variables is made from the contract's table at every build
    (scripts/docs_hooks.py), and the built FMU has exactly the contract's variables."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("docs_hooks", ROOT / "scripts" / "docs_hooks.py")
    hooks = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(hooks)
    assert markdown_table() in hooks.fmu_variables_page()
    rows = {line.split("|")[1].strip() for line in markdown_table().splitlines()[2:]}
    assert rows == {f"`{v.name}`" for v in model_description.modelVariables}


# Equality with the core ---------------------------------------------------------------------------
@pytest.mark.parametrize("fraction, count", [(0.1, 1277), (1e-2, 9894)])
def test_the_chatter_fraction_set_on_the_fmu_is_the_cores(fmu, fraction, count):
    """solver.chatter_fraction as a start value of the FMU: an elastic chatter at a stiff
    structure (ELASTIC_CHATTER) over 0.5 s through FMPy equals the core's run with it, and the
    threshold tells: 1,277 impacts at 0.1 of the period, 9,894 at the default 1e-2."""
    from scenes import ELASTIC_CHATTER

    values = {spec.name: ELASTIC_CHATTER[spec.field] for spec in PARAMETERS
              if spec.field in ELASTIC_CHATTER}
    values["solver.chatter_fraction"] = fraction
    result = fmpy_run(fmu, values, 0.5)
    assert_outputs_equal(result, reference(values, 0.5))
    assert result["contact.count"][-1] == count and result["contact.active"][-1]


@pytest.mark.parametrize("scene", SCENES)
def test_fmpy_equals_simulator(fmu, scene):
    values, t_end = SCENES[scene]
    result = fmpy_run(fmu, values, t_end)
    expected = reference(values, t_end)
    assert_outputs_equal(result, expected)
    assert result["contact.count"][-1] > 0
    if scene == "e0.5":
        assert result["contact.active"][-1]


@pytest.mark.parametrize("method", [2, 3])
def test_fmpy_equals_simulator_with_the_other_solver_methods(fmu, method):
    values = {"solver.method": method, "ice.M": 800.0}
    result = fmpy_run(fmu, values, 3.0)
    assert_outputs_equal(result, reference(values, 3.0))


def test_fmpy_with_method_2_and_nothing_else_changed_finds_every_impact(fmu):
    """solver.method = 2 alone must give a usable run: the sign test is the default detection
    (the article's eq. 26 window, solver.detection = 1, finds no impact of the Figure 2 scene
    and leaves the ice 0.22 m past the structure at 10 s)."""
    result = fmpy_run(fmu, {"solver.method": 2}, 10.0)
    exact = fmpy_run(fmu, {}, 10.0)
    assert result["contact.count"][-1] == exact["contact.count"][-1] > 0
    grid = Scene().flow_u * Scene().solver_dt  # one step's closing distance at most
    assert result["contact.penetration"].max() <= grid
    window = fmpy_run(fmu, {"solver.method": 2, "solver.detection": 1}, 10.0)
    assert window["contact.count"][-1] == 0 and window["contact.penetration"][-1] > 0.2


@pytest.mark.parametrize("scene", SCENES)
def test_impulse_sum_equals_core_total(fmu, scene):
    values, t_end = SCENES[scene]
    result = fmpy_run(fmu, values, t_end)
    # The core's own run, sampled every second: the same total by another partition of time.
    core = run(Scene.from_fmi(values), t_end, dt=1.0)
    total = core.impulse.sum()
    assert total > 0
    assert math.isclose(result["contact.impulse"].sum(), total, rel_tol=1e-9, abs_tol=0.0)
    if not core.sticking.any():  # all of it from impacts
        assert math.isclose(result["contact.impulse"].sum(), core.impacts["impulse"].sum(),
                            rel_tol=1e-9)
    np.testing.assert_allclose(result["contact.force"][1:], result["contact.impulse"][1:] / DT,
                               rtol=1e-9)


def test_ecospy_equals_fmpy(fmu):
    ecospy = pytest.importorskip("ecospy")
    values, t_end = {"ice.M": 800.0}, 10.0
    rows: list[dict] = []

    class Recorder(ecospy.SimulationListener):
        def post(self, info):
            row = {}
            for o in OUTPUTS:
                get = {float: sim.get_real, int: sim.get_integer, bool: sim.get_bool}[o.kind]
                row[o.name] = get(f"ice::{o.name}")
            rows.append(row)

    structure = ecospy.EcosSimulationStructure()
    structure.add_model("ice", str(fmu))
    structure.add_parameter_set("scene", {f"ice::{k}": v for k, v in values.items()})
    with ecospy.EcosSimulation(structure=structure, step_size=DT) as sim:
        sim.add_listener("recorder", Recorder())
        sim.init(parameter_set="scene")
        assert sim.get_real("ice::ice.M") == 800.0
        sim.step(round(t_end / DT))
        sim.terminate()
    got = columns(rows)
    expected = fmpy_run(fmu, values, t_end)
    # FMPy's steps are (k+1)*DT - k*DT, ecospy's exactly DT: equal to rounding.
    assert_outputs_equal(got, {k: expected[k][1:] for k in got}, force_rtol=1e-9)
    # ecospy's steps are exactly DT: bit for bit the core stepped the same way.
    exact = reference(values, t_end, h_exact=True)
    for o in OUTPUTS:
        np.testing.assert_array_equal(got[o.name], exact[o.name][1:], err_msg=o.name)
    assert got["contact.count"][-1] > 0


def test_time_varying_flow_input_is_honoured(fmu):
    t_end = 20.0
    signal = np.array([(0.0, 0.1), (8.0, 0.4), (t_end, 0.05)],
                      dtype=[("time", float), ("flow.u", float)])
    result = simulate_fmu(str(fmu), start_time=0.0, stop_time=t_end, output_interval=DT,
                          input=signal, output=[o.name for o in OUTPUTS] + ["flow.u"])
    applied = result["flow.u"][1:]  # row k+1 holds the u applied during step k
    t_start = result["time"][:-1]
    np.testing.assert_allclose(applied, np.interp(t_start, signal["time"], signal["flow.u"]),
                               rtol=0, atol=1e-12)
    assert_outputs_equal(result, reference({}, t_end, flow=applied))
    constant = fmpy_run(fmu, {}, t_end)
    assert not np.allclose(result["structure.x"], constant["structure.x"][: len(result)])


# Masters stepping by hand -------------------------------------------------------------------------
def test_two_instances_do_not_interfere(fmu_dir, model_description):
    a_values, b_values = {}, {"ice.M": 800.0, "impact.e": 0.5, "drag.model": 2}
    a = Instance(fmu_dir, model_description, "a")
    b = Instance(fmu_dir, model_description, "b")
    # The slave (the FMU's copy of the core, under its private name) guarded PythonFMU's
    # library against its exit-time use-after-free. (Which copy serves it depends on the FMUs
    # loaded before in this process: a copy of the same build, from another folder, is reused.)
    guarded = set().union(*(m._GUARDED_LIBRARIES for n, m in list(sys.modules.items())
                            if n.startswith("_iceimpact_")
                            and n.endswith(".fmi.pythonfmu_fixes")))
    library = Path(fmu_dir) / "binaries" / "linux64" / "pythonfmu" / "IceImpact.so"
    assert os.path.realpath(library) in guarded
    try:
        a.initialize(a_values)
        b.initialize(b_values)
        rows_a, rows_b = [], []
        for k in range(5000):  # interleaved
            rows_a += a.run(1, k)
            rows_b += b.run(1, k)
    finally:
        a.free()
        b.free()
    exp_a, exp_b = reference(a_values, 5.0), reference(b_values, 5.0)
    assert_outputs_equal(columns(rows_a), {k: v[1:] for k, v in exp_a.items()})
    assert_outputs_equal(columns(rows_b), {k: v[1:] for k, v in exp_b.items()})


def test_reset_and_rerun_give_the_same_result(fmu_dir, model_description):
    values = {"ice.M": 2400.0, "impact.e": 0.5}
    inst = Instance(fmu_dir, model_description)
    try:
        inst.initialize(values)
        first = columns(inst.run(3000))
        inst.fmu.reset()
        inst.initialize(values)
        second = columns(inst.run(3000))
    finally:
        inst.free()
    for name in first:
        np.testing.assert_array_equal(first[name], second[name], err_msg=name)
    assert first["contact.count"][-1] > 0


def test_restitution_is_tunable_during_the_run(fmu_dir, model_description):
    inst = Instance(fmu_dir, model_description)
    try:
        inst.initialize({})
        rows = inst.run(5000)
        inst.set({"impact.e": 0.5})
        rows += inst.run(10000, 5000)
    finally:
        inst.free()
    sim = Simulator(Scene())
    reports = []
    for k in range(15000):
        if k == 5000:
            sim.set_restitution(0.5)
        reports.append(sim.advance((k + 1) * DT - k * DT, 0.1))
    expected = {o.name: np.array([getattr(r, o.field) for r in reports]) for o in OUTPUTS}
    assert_outputs_equal(columns(rows), expected)
    unchanged = reference({}, 15.0)
    assert not np.allclose(columns(rows)["structure.x"], unchanged["structure.x"][1:])


def test_fmu_state_get_set_and_serialize_reproduce_the_continuation(fmu_dir, model_description):
    values = {"impact.e": 0.5}  # the continuation crosses impacts and the start of sticking
    inst = Instance(fmu_dir, model_description, "original")
    other = None
    try:
        inst.initialize(values)
        inst.run(8000)
        state = inst.fmu.getFMUstate()
        continuation = columns(inst.run(4000, 8000))
        assert continuation["contact.active"][-1]

        inst.fmu.setFMUstate(state)
        again = columns(inst.run(4000, 8000))
        inst.fmu.setFMUstate(state)  # a state can be set more than once
        third = columns(inst.run(4000, 8000))

        data = inst.fmu.serializeFMUstate(state)
        inst.fmu.freeFMUstate(state)
        other = Instance(fmu_dir, model_description, "restored")
        other.initialize({})  # default scene: the state brings its own
        restored_state = other.fmu.deSerializeFMUstate(data)
        other.fmu.setFMUstate(restored_state)
        restored = columns(other.run(4000, 8000))
        other.fmu.freeFMUstate(restored_state)
    finally:
        inst.free()
        if other is not None:
            other.free()
    for name in continuation:
        np.testing.assert_array_equal(again[name], continuation[name], err_msg=name)
        np.testing.assert_array_equal(third[name], continuation[name], err_msg=name)
        np.testing.assert_array_equal(restored[name], continuation[name], err_msg=name)
    assert not errors(inst) and not errors(other)


# Bad inputs ---------------------------------------------------------------------------------------
BAD_PARAMETERS = [
    ("ice.M", -1.0, "ice.M = -1.0 is not allowed: > 0"),
    ("structure.k", float("nan"), "structure.k = nan is not allowed: finite, > 0"),
    ("fluid.rho", float("inf"), "fluid.rho = inf is not allowed: finite, > 0"),
    ("structure.m", 0.0, "structure.m = 0.0 is not allowed: > 0"),
    ("impact.e", 1.5, "impact.e = 1.5 is not allowed: 0 <= e <= 1"),
    ("drag.model", 3, "drag.model = 3 is not allowed: 1 or 2"),
    ("ice.z0", 0.5, "ice.z0 = 0.5 is not allowed: <= structure.x0"),
    ("solver.method", 4, "solver.method = 4 is not allowed: 1, 2 or 3"),
    ("solver.dt", 0.0, "solver.dt = 0.0 is not allowed: >= 1e-9"),
    ("solver.rtol", 1.0, "solver.rtol = 1.0 is not allowed: 1e-13 <= rtol < 1"),
    ("flow.u", float("nan"), "flow.u = nan is not allowed"),
]


@pytest.mark.parametrize(("name", "value", "message"), BAD_PARAMETERS,
                         ids=[f"{n}={v}" for n, v, _ in BAD_PARAMETERS])
def test_bad_parameter_is_reported_and_the_instance_survives(fmu_dir, model_description, name,
                                                             value, message):
    inst = Instance(fmu_dir, model_description)
    try:
        # OK (libcosim terminates the process on fmi2Error here): the error is logged ...
        assert inst.initialize({name: value}) == FMI_OK
        assert message in errors(inst)
        assert any(s == FMI_ERROR and c == "logStatusError" for s, c, _ in inst.messages)
        assert inst.step(0.0, DT) == FMI_ERROR  # ... and every step fails (fail_call)
        assert f"doStep refused: exitInitializationMode: {message}" in errors(inst)
        assert_outputs_finite(inst)
        inst.fmu.terminate()
    finally:
        inst.free()


@pytest.mark.parametrize("value", [float("nan"), float("inf"), -float("inf")])
def test_non_finite_flow_during_the_run_is_discarded(fmu_dir, model_description, value):
    inst = Instance(fmu_dir, model_description)
    try:
        inst.initialize({})
        inst.run(100)
        before = inst.outputs()
        inst.set({"flow.u": value})
        assert inst.step(100 * DT, DT) == FMI_DISCARD
        assert f"flow.u = {value!r} is not allowed: a finite real number (m/s)" in errors(inst)
        assert inst.outputs() == before  # outputs keep their last valid values
        assert_outputs_finite(inst)
    finally:
        inst.free()


def test_bad_restitution_during_the_run_is_discarded(fmu_dir, model_description):
    inst = Instance(fmu_dir, model_description)
    try:
        inst.initialize({})
        inst.run(10)
        inst.set({"impact.e": -0.1})
        assert inst.step(10 * DT, DT) == FMI_DISCARD
        assert "impact.e = -0.1 is not allowed: 0 <= e <= 1" in errors(inst)
        inst.set({"impact.e": 0.5})  # a valid value is taken at the next step
        assert inst.step(10 * DT, DT) == FMI_OK
    finally:
        inst.free()


def test_fixed_parameter_after_initialization_is_refused_and_not_stored(fmu_dir,
                                                                         model_description):
    inst = Instance(fmu_dir, model_description)
    try:
        inst.initialize({})
        rows = inst.run(500)
        with pytest.raises(FMICallException) as refused:  # fmi2SetReal returns fmi2Error
            inst.set({"structure.m": 800.0})
        assert refused.value.status == FMI_ERROR
        in_use = inst.fmu.getReal([inst.variables["structure.m"].valueReference])[0]
        rows += inst.run(500, 500)
    finally:
        inst.free()
    refusals = [m for s, c, m in inst.messages if s == FMI_ERROR]
    assert any("structure.m is a fixed parameter: setting it to 800.0 after initialization is "
               "refused and the value in use, 1600.0, is kept" in m for m in refusals)
    assert in_use == 1600.0  # fmi2Get gives the value the simulation uses
    expected = reference({}, 1.0)
    assert_outputs_equal(columns(rows), {k: v[1:] for k, v in expected.items()})


@pytest.mark.parametrize(("t", "h", "message"), [
    (0.0, 0.0, "communication step size = 0.0 s is not allowed: finite and > 0"),
    (0.0, -1e-3, "communication step size = -0.001 s is not allowed: finite and > 0"),
    (0.0, float("nan"), "communication step size = nan s is not allowed"),
    (0.0, float("inf"), "communication step size = inf s is not allowed"),
    (0.5, 1e-3, "current communication point = 0.5 s does not match the time of the FMU, 0.0 s"),
    (-1e-3, 1e-3, "current communication point = -0.001 s does not match"),
])
def test_bad_step_is_reported_and_the_run_can_go_on(fmu_dir, model_description, t, h, message):
    inst = Instance(fmu_dir, model_description)
    try:
        inst.initialize({})
        before = inst.outputs()
        assert inst.step(t, h) == FMI_DISCARD
        assert message in errors(inst)
        assert inst.outputs() == before
        rows = columns(inst.run(1000))  # nothing was changed by the refused step
    finally:
        inst.free()
    expected = reference({}, 1.0)
    assert_outputs_equal(rows, {k: v[1:] for k, v in expected.items()})


def test_time_mismatch_after_steps(fmu_dir, model_description):
    inst = Instance(fmu_dir, model_description)
    try:
        inst.initialize({})
        inst.run(10)
        assert inst.step(0.009, DT) == FMI_DISCARD  # repeats a step
        assert "current communication point = 0.009 s does not match the time of the FMU" in (
            errors(inst))
    finally:
        inst.free()


def test_start_time_offsets_the_time_of_the_last_impact(fmu_dir, model_description):
    inst = Instance(fmu_dir, model_description)
    try:
        inst.initialize({}, start=100.0)
        for k in range(1500):
            t0, t1 = 100.0 + k * DT, 100.0 + (k + 1) * DT
            assert inst.step(t0, t1 - t0) == FMI_OK, errors(inst)
        out = inst.outputs()
    finally:
        inst.free()
    impacts = run(Scene(), 1.5, dt=0.5).impacts["t"]
    assert out["contact.count"] == len(impacts) >= 1
    assert math.isclose(out["contact.t_last"], 100.0 + impacts[-1], abs_tol=1e-9)


# C host -------------------------------------------------------------------------------------------
def _libpython() -> Path | None:
    libdir = sysconfig.get_config_var("LIBDIR")
    name = sysconfig.get_config_var("LDLIBRARY")
    if not libdir or not name or not name.endswith(".so") and ".so." not in name:
        return None
    path = Path(libdir) / name
    return path if path.exists() else None


@pytest.fixture(scope="session")
def c_host(fmu_dir, tmp_path_factory):
    """(command prefix, environment) to run tests/c_host/host.c on the extracted FMU."""
    gcc = shutil.which("gcc") or shutil.which("cc")
    libpython = _libpython()
    if gcc is None:
        pytest.skip("no C compiler")
    if libpython is None:
        pytest.skip("this Python has no shared libpython to preload")
    exe = tmp_path_factory.mktemp("c_host") / "host"
    subprocess.run([gcc, "-O2", "-Wall", "-Wextra", "-Werror", "-o", str(exe),
                    str(ROOT / "tests" / "c_host" / "host.c"), "-ldl"], check=True)
    paths = dict.fromkeys([sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"]])
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}
    env.update(LD_PRELOAD=str(libpython), PYTHONPATH=os.pathsep.join(paths))
    return [str(exe), fmu_dir], env


def run_host(c_host, *args: str) -> subprocess.CompletedProcess:
    command, env = c_host
    return subprocess.run([*command, *args], env=env, capture_output=True, text=True,
                          timeout=120)


def test_c_host_equals_fmpy(fmu, c_host):
    done = run_host(c_host, "-n", "2000", "-h", "0.001", "-s", "ice.M=800")
    assert done.returncode == 0, done.stderr
    lines = done.stdout.strip().splitlines()
    header = lines[0].split(",")
    assert header == ["time"] + [o.name for o in OUTPUTS]
    data = np.array([[float(x) for x in line.split(",")] for line in lines[1:]])
    assert data.shape == (2001, len(header))
    expected = fmpy_run(fmu, {"ice.M": 800.0}, 2.0)
    np.testing.assert_array_equal(data[:, 0], expected["time"])
    got = {name: data[:, i] for i, name in enumerate(header)}
    assert_outputs_equal(got, {o.name: np.asarray(expected[o.name]) for o in OUTPUTS})
    assert got["contact.count"][-1] > 0


def test_c_host_reports_bad_parameter_and_exits_cleanly(c_host):
    done = run_host(c_host, "-n", "10", "-s", "ice.M=-1")
    assert done.returncode == 4, done.stderr  # the host's code for a non-OK doStep
    assert "ice.M = -1.0 is not allowed: > 0" in done.stderr
    assert "fmi2DoStep at t = 0 returned 3" in done.stderr


@pytest.mark.parametrize("keep_loaded", [False, True], ids=["dlclose", "no-dlclose"])
def test_c_host_exits_cleanly_every_time(c_host, keep_loaded):
    """PythonFMU's exit-time use-after-free (see docs/explanation/fmu-loader.md) is neutralised by
    the
    slave."""
    flags = ["-k"] if keep_loaded else []
    codes = [run_host(c_host, "-n", "20", *flags).returncode for _ in range(8)]
    assert codes == [0] * len(codes)


@pytest.mark.slow
def test_c_host_exits_cleanly_soak(c_host):
    codes = [run_host(c_host, "-n", "200", "-s", "impact.e=0.5").returncode for _ in range(60)]
    assert codes == [0] * len(codes)
