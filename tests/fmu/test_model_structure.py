"""ModelStructure of both FMUs: the dependencies declared for every output against what the FMUs
do, then FMPy's validator, fmu-manipulation-toolbox's checker and OMSimulator on the result.

The declarations come from the contract tables (``Variable.depends_on``, within a communication
step; ``Variable.initial_depends_on``, after initialization). They are measured here with FMPy's
FMU2Slave:

- within a step: after initialization and a few steps, each input is set to another value and
  every output read again before the next fmi2DoStep (and the same in Initialization Mode);
- after initialization: each known (parameter or input) in turn is given another valid value
  before fmi2ExitInitializationMode, and the outputs are compared with those of the base scene,
  both as read in Initialization Mode and after it. The base scenes are chosen so that every
  declared dependency shows (a moving structure away from its rest position, an external
  structure with the ice past it, bodies touching at a closing speed of rounding size).
"""

from __future__ import annotations

import importlib.util
import json
import math
import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from fmpy import extract, read_model_description
from fmpy.validation import validate_fmu

from fmu_host import FMI_ERROR, FMI_OK, ROOT, Instance, build_module, toolbox_check
from iceimpact import contract
from iceimpact.modal import contract as modal_contract
from iceimpact.modal.fmu import default_values, structure_from_values
from iceimpact.scene import ParameterError, Scene

OMSIMULATOR = ROOT.parent / "shared" / "tools" / "omsimulator"
H = 1e-3

# Base scenes of IceImpact.fmu for the knowns after initialization (see the module docstring).
ICE_INITIAL_SCENES = {
    # apart, both moving, the structure off its rest position (k x0 shows in structure.force)
    "apart": {"structure.x0": 0.02, "structure.v0": 0.05, "ice.z0": 0.01, "ice.v0": 0.01},
    # the ice 5 mm past an external structure, which starts at x = 0 (a built-in one at x0 is
    # 5 mm ahead of the ice: penetration 0)
    "external": {"structure.model": contract.STRUCTURE_EXTERNAL, "structure.x0": 0.01,
                 "ice.z0": 0.005},
    # touching, closing at 1e-14 m/s: an impact at the start without flow, a speed at rounding
    # level (no impact; the flow then presses the ice on: sticking) with it
    "touching": {"ice.z0": 0.0, "ice.v0": 1e-14, "flow.u": 0.0},
    # the modal structure, every mode used, seen at the contact point and moving (each mode's
    # phi, q0 and v0 show in x, v and its own q, v); the ice upstream of sum phi q0 = 5 mm
    "modal": {"structure.model": contract.STRUCTURE_MODAL,
              "structure.modes": contract.MAX_MODES, "ice.z0": 0.0} | {
        name: value for k in range(1, contract.MAX_MODES + 1) for name, value in (
            (f"structure.mode{k}.phi", 1.0 / k), (f"structure.mode{k}.q0", 1e-3 * k),
            (f"structure.mode{k}.v0", -2e-3 * k))},
}
# Base scenes for the inputs within a step: the built-in structure, and an external one under a
# Jacobi master with the ice pressed on it by the flow (coupling.force is then a prediction).
ICE_STEP_SCENES = {
    "built-in": {"flow.u": 0.3},
    "riding": {"structure.model": contract.STRUCTURE_EXTERNAL,
               "coupling.scheme": contract.SCHEME_JACOBI, "ice.z0": 0.0, "ice.v0": 0.0,
               "flow.u": 0.3},
    # two modes riding with the ice pressed on: the load inputs act from the next step only
    "modal": {"structure.model": contract.STRUCTURE_MODAL, "structure.modes": 2,
              "structure.mode2.f": 11.0, "structure.mode2.phi": 0.6, "ice.z0": 0.0,
              "ice.v0": 0.0, "impact.e": 0.0, "flow.u": 0.3},
}
# Every mode used and moving, a force on: each mode parameter and the force show in x, v, a.
MODAL_SCENE = {"modes": modal_contract.MAX_MODES, "force": 250.0} | {
    name: value for k in range(1, modal_contract.MAX_MODES + 1) for name, value in (
        (f"mode{k}.f", 1.0 + k), (f"mode{k}.zeta", 0.01 * k), (f"mode{k}.m", 1000.0 * k),
        (f"mode{k}.phi", 1.0 / k), (f"mode{k}.q0", 1e-3 * k), (f"mode{k}.v0", -2e-3 * k))}
MODAL_STEP_SCENES = {"one mode": {"force": 100.0}, "five modes": MODAL_SCENE}


def valid_ice(values: dict) -> bool:
    try:
        Scene.from_fmi({k: v for k, v in values.items() if k in contract.SCENE_VARIABLES})
    except ParameterError:
        return False
    return True


def valid_modal(values: dict) -> bool:
    try:
        structure_from_values(default_values() | {
            k: v for k, v in values.items() if k != modal_contract.FORCE_INPUT.name})
    except ParameterError:
        return False
    return True


class Probe:
    """One FMU2Slave of an FMU whose variables are the contract ``table``'s."""

    def __init__(self, fmu_dir: str, table, valid):
        md = read_model_description(fmu_dir)
        self.inst = Instance(fmu_dir, md, name=md.coSimulation.modelIdentifier)
        self.table = table
        self.valid = valid
        self.knowns = table.PARAMETERS + table.INPUTS
        kind = {float: "Real", int: "Integer", bool: "Boolean"}
        self._get = {k: getattr(self.inst.fmu, f"get{name}") for k, name in kind.items()}
        self._set = {k: getattr(self.inst.fmu, f"set{name}") for k, name in kind.items()}

    def _vr(self, name: str) -> int:
        return self.inst.variables[name].valueReference

    def outputs(self) -> dict:
        return {o.name: self._get[o.kind]([self._vr(o.name)])[0] for o in self.table.OUTPUTS}

    def set(self, name: str, value) -> None:
        self._set[self.table.BY_NAME[name].kind]([self._vr(name)], [value])

    def scene(self, base: dict) -> dict:
        """Every known's value: the start values, then ``base``."""
        values = {v.name: v.start for v in self.knowns} | base
        assert self.valid(values), base
        return values

    def start(self, values: dict, in_initialization=None) -> tuple[dict, dict]:
        """Reset, set ``values`` and initialize: the outputs read in Initialization Mode (after
        the values are set, and after ``in_initialization()`` if given) and after it."""
        self.inst.fmu.reset()
        self.inst.messages.clear()
        self.inst.fmu.setupExperiment(startTime=0.0)
        for name, value in values.items():
            self.set(name, value)
        self.inst.fmu.enterInitializationMode()
        if in_initialization is not None:
            in_initialization()
        during = self.outputs()
        self.inst.fmu.exitInitializationMode()
        errors = [m for status, _, m in self.inst.messages if status >= FMI_ERROR]
        assert not errors, (values, errors)
        return during, self.outputs()

    def other_value(self, values: dict, name: str):
        """A value of ``name`` other than its value in ``values`` that keeps the scene valid."""
        spec = self.table.BY_NAME[name]
        current = values[name]
        if spec.choices:
            candidates = [c for c in spec.choices if c != current]
        elif spec.kind is int:
            candidates = [current + 1, current - 1]
        else:  # a change of 0.1 or half the value, either way
            delta = 0.5 * abs(current) + 0.1
            candidates = [current + delta, current - delta]
        for candidate in candidates:
            if self.valid(values | {name: candidate}):
                return candidate
        return None

    def free(self) -> None:
        self.inst.free()


def changed(before: dict, after: dict) -> set[str]:
    return {name for name in before if after[name] != before[name]}


def measure_initial(probe: Probe, base: dict) -> tuple[dict[str, set[str]], list[str]]:
    """Output -> the knowns whose change before fmi2ExitInitializationMode changes it (read in
    Initialization Mode or after it), and the knowns that had no other valid value."""
    values = probe.scene(base)
    during, after = probe.start(values)
    found: dict[str, set[str]] = {o.name: set() for o in probe.table.OUTPUTS}
    fixed = []
    for known in probe.knowns:
        other = probe.other_value(values, known.name)
        if other is None:
            fixed.append(known.name)
            continue
        during2, after2 = probe.start(values | {known.name: other})
        for output in changed(during, during2) | changed(after, after2):
            found[output].add(known.name)
    return found, fixed


def measure_step(probe: Probe, base: dict, steps: int = 5) -> dict[str, set[str]]:
    """Output -> the inputs whose fmi2Set changes its fmi2Get without an fmi2DoStep between, in
    Initialization Mode and after ``steps`` steps."""
    values = probe.scene(base)
    found: dict[str, set[str]] = {o.name: set() for o in probe.table.OUTPUTS}

    def probe_inputs() -> None:
        for spec in probe.table.INPUTS:
            before = probe.outputs()
            probe.set(spec.name, values[spec.name] + 0.37)
            for output in changed(before, probe.outputs()):
                found[output].add(spec.name)
            probe.set(spec.name, values[spec.name])
            assert probe.outputs() == before

    probe.start(values, in_initialization=probe_inputs)
    for k in range(steps):
        assert probe.inst.step(k * H, H) == FMI_OK, probe.inst.messages
    probe_inputs()
    return found


@pytest.fixture(scope="module")
def modal_fmu(tmp_path_factory) -> Path:
    return build_module().build_modal(tmp_path_factory.mktemp("modal_structure"))


@pytest.fixture(scope="module")
def ice_probe(fmu_dir):
    probe = Probe(fmu_dir, contract, valid_ice)
    yield probe
    probe.free()


@pytest.fixture(scope="module")
def modal_probe(modal_fmu, tmp_path_factory):
    probe = Probe(extract(str(modal_fmu), unzipdir=str(tmp_path_factory.mktemp("modal"))),
                  modal_contract, valid_modal)
    yield probe
    probe.free()


def declared(fmu: Path, section: str) -> dict[str, dict[str, str]]:
    """Output -> {known: dependenciesKind} as modelDescription.xml's ModelStructure has them."""
    md = read_model_description(str(fmu))
    rows = md.outputs if section == "Outputs" else md.initialUnknowns
    result = {}
    for unknown in rows:
        assert unknown.dependencies is not None, f"{unknown.variable.name}: no dependencies"
        result[unknown.variable.name] = dict(zip(
            (v.name for v in unknown.dependencies), unknown.dependenciesKind, strict=True))
    return result


@pytest.mark.parametrize("which", ["IceImpact", "ModalStructure"])
def test_model_description_declares_the_contract(which, fmu, modal_fmu):
    path, table = (fmu, contract) if which == "IceImpact" else (modal_fmu, modal_contract)
    assert declared(path, "Outputs") == {o.name: o.depends_on for o in table.OUTPUTS}
    assert declared(path, "InitialUnknowns") == {
        o.name: dict.fromkeys(o.initial_depends_on, contract.DEPENDENT) for o in table.OUTPUTS}


def test_ice_outputs_depend_on_no_input_within_a_step(ice_probe):
    for scene, base in ICE_STEP_SCENES.items():
        found = measure_step(ice_probe, base)
        assert found == {o.name: set(o.depends_on) for o in contract.OUTPUTS}, scene
    assert all(not o.depends_on for o in contract.OUTPUTS)  # stored at the end of each step


def test_modal_acceleration_depends_on_the_force_within_a_step(modal_probe):
    for scene, base in MODAL_STEP_SCENES.items():
        found = measure_step(modal_probe, base)
        assert found == {o.name: set(o.depends_on) for o in modal_contract.OUTPUTS}, scene
    assert modal_contract.BY_NAME["a"].depends_on == {"force": contract.FIXED}


def test_modal_acceleration_is_the_force_times_a_fixed_factor(modal_probe):
    """dependenciesKind "fixed": a changes with the force by sum(phi^2 / m) over the modes used,
    at every communication point."""
    values = modal_probe.scene(MODAL_SCENE)
    modal_probe.start(values)
    factor = math.fsum(values[f"mode{k}.phi"] ** 2 / values[f"mode{k}.m"]
                       for k in range(1, values["modes"] + 1))
    for k in range(3):
        if k:
            assert modal_probe.inst.step((k - 1) * 0.01, 0.01) == FMI_OK
        a = {}
        for force in (-300.0, 0.0, 1200.0):
            modal_probe.set("force", force)
            a[force] = modal_probe.outputs()["a"]
        assert a[1200.0] - a[0.0] == pytest.approx(1200.0 * factor, rel=1e-12)
        assert a[0.0] - a[-300.0] == pytest.approx(300.0 * factor, rel=1e-12)
        modal_probe.set("force", values["force"])


def test_ice_initial_outputs_depend_on_the_declared_knowns(ice_probe):
    found: dict[str, set[str]] = {o.name: set() for o in contract.OUTPUTS}
    for base in ICE_INITIAL_SCENES.values():
        for output, knowns in measure_initial(ice_probe, base)[0].items():
            found[output] |= knowns
    # structure.modes from k - 1 to k switches mode k on (the base scene has it at its maximum:
    # the measure above sees mode 5 only)
    values = ice_probe.scene(ICE_INITIAL_SCENES["modal"])
    for k in range(2, contract.MAX_MODES + 1):
        fewer = ice_probe.start(values | {"structure.modes": k - 1})
        more = ice_probe.start(values | {"structure.modes": k})
        for output in changed(fewer[0], more[0]) | changed(fewer[1], more[1]):
            found[output].add("structure.modes")
    inputs = {v.name for v in contract.INPUTS}
    for spec in contract.OUTPUTS:
        declared_knowns = set(spec.initial_depends_on)
        # the inputs, for every output: flow.u decides the contact at the start only
        assert found[spec.name] & inputs == declared_knowns & inputs, spec.name
        if spec.initial_depends_on == contract.START_CONTACT:
            # the contact rules see the whole scene: declared in full, measured in part
            assert found[spec.name] <= declared_knowns, spec.name
        else:
            assert found[spec.name] == declared_knowns, spec.name
    # in the touching scene the contact at the start turns on the flow, the method and the
    # start state
    assert found["contact.count"] >= {"flow.u", "solver.method", "structure.model",
                                      "structure.x0", "structure.v0", "ice.z0"}


def test_modal_initial_outputs_depend_on_the_declared_knowns(modal_probe):
    found, fixed = measure_initial(modal_probe, MODAL_SCENE)
    assert fixed == []
    assert found == {o.name: set(o.initial_depends_on) for o in modal_contract.OUTPUTS}


# Validators ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("which", ["IceImpact", "ModalStructure"])
def test_fmpy_validation_finds_no_problem(which, fmu, modal_fmu):
    assert validate_fmu(str(fmu if which == "IceImpact" else modal_fmu)) == []


@pytest.mark.parametrize("which", ["IceImpact", "ModalStructure"])
def test_fmu_manipulation_toolbox_checker_finds_no_problem(which, fmu, modal_fmu):
    """The checkers of ``fmutool -check``: the FMI 2.0 schema and the standard's rules beyond it
    (Outputs and InitialUnknowns entries, their dependencies and dependenciesKind)."""
    warnings, version, errors = toolbox_check(fmu if which == "IceImpact" else modal_fmu)
    assert (warnings, version, errors) == ([], "2.0", [])


# OMSimulator ------------------------------------------------------------------------------------
# The coupled system of examples/system/system.py (its CONNECTIONS), its components named here so
# that OMSimulator's name handling leaves the variables alone (a component named like the prefix of
# a variable, ice with ice.M, loses it; a path part "model" is dropped).
OMS_SCRIPT = '''
import json
import sys
from OMSimulator import SSP, CRef

folder, connections = sys.argv[1], json.loads(sys.argv[2])
model = SSP()
for name in ("IceImpact", "ModalStructure"):
    model.addResource(f"{folder}/{name}.fmu", new_name=f"resources/{name}.fmu")
model.addComponent(CRef("default", "floe"), "resources/IceImpact.fmu")
model.addComponent(CRef("default", "tower"), "resources/ModalStructure.fmu")
for a, out, b, inp in connections:
    model.addConnection(CRef("default", a, out), CRef("default", b, inp))
instance = model.instantiate()
instance.setResultFile(f"{folder}/result.csv")
instance.setStopTime(0.01)
instance.setFixedStepSize(1e-3)
instance.initialize()
instance.simulate()
x = instance.getValue(CRef("default", "tower", "x"))
print("simulated to 0.01 s: tower.x =", x, flush=True)
instance.terminate()
instance.delete()
'''


def connections() -> list[tuple[str, str, str, str]]:
    """examples/system/system.py's CONNECTIONS between the components floe (IceImpact.fmu) and
    tower (ModalStructure.fmu), each end told apart by its FMU's variable names."""
    spec = importlib.util.spec_from_file_location("system", ROOT / "examples/system/system.py")
    system = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(system)

    def component(variable: str) -> str:
        if variable in modal_contract.BY_NAME:
            return "tower"
        assert variable in contract.BY_NAME, variable
        return "floe"

    return [(component(out), out, component(inp), inp)
            for _, out, _, inp in system.CONNECTIONS]


def run_omsimulator(folder: Path) -> str:
    """Load and run the coupled system of the two FMUs in ``folder``; OMSimulator's output."""
    if not (OMSIMULATOR / "python" / "OMSimulator").is_dir():
        pytest.skip(f"no OMSimulator build at {OMSIMULATOR} (../shared/tools/omsimulator)")
    pytest.importorskip("lxml", reason="OMSimulator's Python package needs lxml")
    env = os.environ | {"PYTHONPATH": str(OMSIMULATOR / "python")}
    done = subprocess.run(
        [sys.executable, "-c", OMS_SCRIPT, str(folder), json.dumps(connections())], env=env,
        capture_output=True, text=True, timeout=120)
    output = done.stdout + done.stderr
    assert done.returncode == 0, output
    assert "simulated to 0.01 s" in output, output
    return output


def has_algebraic_loop(output: str) -> bool:
    return re.search(r"alg(\.|ebraic) loop", output, re.IGNORECASE) is not None


def test_omsimulator_finds_no_algebraic_loop(fmu, modal_fmu, tmp_path):
    for path in (fmu, modal_fmu):
        shutil.copy(path, tmp_path)
    output = run_omsimulator(tmp_path)
    assert not has_algebraic_loop(output), output


def test_omsimulator_saw_a_loop_without_the_dependencies(fmu, modal_fmu, tmp_path):
    """The check above can fail: without dependencies (every output depending on every known)
    OMSimulator reports the loop through x, v, a and coupling.force."""
    for path in (fmu, modal_fmu):
        with zipfile.ZipFile(path) as src, zipfile.ZipFile(tmp_path / path.name, "w") as dst:
            for info in src.infolist():
                data = src.read(info)
                if info.filename == "modelDescription.xml":
                    data = re.sub(rb' dependencies(Kind)?="[^"]*"', b"", data)
                dst.writestr(info, data)
    output = run_omsimulator(tmp_path)
    assert has_algebraic_loop(output), output
