"""IceImpact3.fmu and ModalStructure3.fmu, the FMI 3.0 Co-Simulation FMUs, in FMPy.

The same contract rendered for FMI 3.0 (variables, units, ranges, dependencies, experiment), the
checkers clean, the same outputs as the FMI 2.0 FMU to the bit, early return at every contact
event with its samples exact, event mode, the FMU state, and the refusals with their statuses.
The native hosts and the failure paths outside Python are in tests/fmu/test_native_hosts.py and
tests/fmu/test_host_failures.py.
"""

from __future__ import annotations

import zipfile
from ctypes import c_char_p
from xml.etree import ElementTree as ET

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi3 import FMU3Slave
from fmpy.validation import validate_fmu

from fmu_host import build_module, toolbox_check
from iceimpact import Scene, Simulator
from iceimpact.contract import BY_NAME
from iceimpact.fmi.lifecycle import REACHED_TIME
from iceimpact.fmi.slave_base import FMI3_CHANNEL

DISCARD, ERROR = 2, 3


@pytest.fixture(scope="module")
def modal_pair(fmus3, tmp_path_factory):
    """ModalStructure.fmu and ModalStructure3.fmu of this session."""
    folder = tmp_path_factory.mktemp("modal2")
    return build_module().build_modal(folder), fmus3 / "ModalStructure3.fmu"


def _variables(md) -> dict:
    return {v.name: v for v in md.modelVariables}


# The contract, rendered for FMI 3.0 ---------------------------------------------------------------
_TYPES = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean", "String": "String"}
_SAME = ("valueReference", "causality", "variability", "initial", "description", "start", "min",
         "max", "unit")


@pytest.mark.parametrize("which", ["IceImpact", "ModalStructure"])
def test_the_fmi3_description_has_the_fmi2_variables_experiment_and_dependencies(
        which, fmu, fmus3, modal_pair):
    two = read_model_description(str(fmu if which == "IceImpact" else modal_pair[0]))
    three = read_model_description(str(fmus3 / f"{which}3.fmu"))
    v2, v3 = _variables(two), _variables(three)
    assert three.fmiVersion == "3.0" and three.modelName == two.modelName == which
    assert set(v3) - set(v2) == {"time"} and set(v2) <= set(v3)
    for name, a in v2.items():
        b = v3[name]
        assert _TYPES[a.type] == b.type, name
        for key in _SAME:
            assert getattr(a, key) == getattr(b, key), (name, key)
    time = v3["time"]
    assert (time.causality, time.variability, time.type, time.valueReference) == (
        "independent", "continuous", "Float64", FMI3_CHANNEL[REACHED_TIME][0])
    e2, e3 = two.defaultExperiment, three.defaultExperiment
    assert (e2.startTime, e2.stopTime, e2.stepSize) == (e3.startTime, e3.stopTime, e3.stepSize)
    for kind in ("outputs", "initialUnknowns"):
        deps2 = {u.variable.name: [d.name for d in u.dependencies] for u in getattr(two, kind)}
        deps3 = {u.variable.name: [d.name for d in u.dependencies] for u in getattr(three, kind)}
        assert deps2 == deps3, kind
        kinds2 = {u.variable.name: u.dependenciesKind for u in getattr(two, kind)}
        kinds3 = {u.variable.name: u.dependenciesKind for u in getattr(three, kind)}
        assert kinds2 == kinds3, kind
    assert [u.name for u in two.unitDefinitions] == [
        u.name for u in three.unitDefinitions if u.name in {w.name for w in two.unitDefinitions}]
    with zipfile.ZipFile(fmus3 / f"{which}3.fmu") as archive:
        cs = ET.fromstring(archive.read("modelDescription.xml")).find("CoSimulation").attrib
    assert cs["modelIdentifier"] == f"{which}3"
    for flag in ("canGetAndSetFMUState", "canSerializeFMUState", "hasEventMode",
                 "canHandleVariableCommunicationStepSize"):
        assert cs[flag] == "true", flag
    assert cs["mightReturnEarlyFromDoStep"] == ("true" if which == "IceImpact" else "false")


@pytest.mark.parametrize("which", ["IceImpact3", "ModalStructure3"])
def test_fmpy_and_fmu_manipulation_toolbox_find_no_problem(which, fmus3):
    path = fmus3 / f"{which}.fmu"
    assert validate_fmu(str(path)) == []
    warnings, version, errors = toolbox_check(path)
    assert (warnings, version, errors) == ([], "3.0", [])


# The same outputs as the FMI 2.0 FMU -------------------------------------------------------------
SCENES = {
    "default": {},
    "e = 0.5, quadratic": {"impact.e": 0.5, "drag.model": 2, "ice.A": 2.0},
    "plastic, sticking": {"impact.e": 0.0},
    "method 2": {"solver.method": 2},
    "method 3": {"solver.method": 3, "impact.e": 0.5},
    "Morison": {"structure.Ca": 1.0, "structure.V": 0.5, "structure.Cd": 1.2,
                "structure.A": 1.0, "impact.e": 0.5},
}


def _flow_steps():
    signal = np.zeros(3, dtype=[("time", float), ("flow.u", float)])
    signal["time"] = [0.0, 4.0, 7.0]
    signal["flow.u"] = [0.2, -0.05, 0.4]
    return signal


@pytest.mark.parametrize("scene", list(SCENES), ids=list(SCENES))
def test_every_output_equals_the_fmi2_fmus_to_the_bit(scene, fmu, fmu3):
    options = dict(stop_time=10.0, output_interval=1e-2, start_values=SCENES[scene],
                   input=_flow_steps() if scene == "default" else None)
    two = simulate_fmu(str(fmu), **options)
    three = simulate_fmu(str(fmu3), **options)
    assert two.dtype.names == three.dtype.names
    for name in two.dtype.names:
        assert np.array_equal(two[name], three[name]), name
    assert two["contact.count"][-1] > 0


def test_the_modal_structure_outputs_equal_the_fmi2_fmus(modal_pair):
    signal = np.zeros(3, dtype=[("time", float), ("force", float)])
    signal["time"], signal["force"] = [0.0, 0.3, 0.6], [1000.0, -500.0, 0.0]
    options = dict(stop_time=2.0, output_interval=1e-3, input=signal,
                   start_values={"modes": 2, "mode2.f": 3.0, "mode2.phi": 0.5})
    two = simulate_fmu(str(modal_pair[0]), **options)
    three = simulate_fmu(str(modal_pair[1]), **options)
    for name in two.dtype.names:
        assert np.array_equal(two[name], three[name]), name


# Early return: a sample at every contact event ----------------------------------------------------
def _core_impacts(changes: dict, t_end: float, h: float) -> list[float]:
    sim = Simulator(Scene(**changes))
    for k in range(round(t_end / h)):
        sim.advance_to((k + 1) * h)
    return [impact.t for impact in sim.impacts]


@pytest.mark.parametrize("scene", ["default", "e = 0.5, quadratic", "plastic, sticking"])
def test_early_return_gives_a_sample_at_each_impact_time_exactly(scene, fmu, fmu3):
    values = SCENES[scene]
    h, t_end = 1e-2, 20.0
    grid = simulate_fmu(str(fmu), stop_time=t_end, output_interval=h, start_values=values)
    early = simulate_fmu(str(fmu3), stop_time=t_end, output_interval=h, start_values=values,
                         early_return_allowed=True)
    changes = {BY_NAME[name].field: value for name, value in values.items()}
    impacts = _core_impacts(changes, t_end, h)
    assert impacts
    times = early["time"]
    assert set(impacts) <= set(times.tolist())  # exact: the impact times themselves
    at = np.isin(times, impacts)
    impacts_in_step = np.diff(early["contact.count"], prepend=0)
    assert np.all(early["contact.t_last"][at] == times[at])
    assert np.all(impacts_in_step[at] >= 1)
    # the other early samples are separations: no impact in the step, the bodies apart
    on_grid = np.isin(times, grid["time"])
    other = ~at & ~on_grid
    assert np.all(impacts_in_step[other] == 0)
    assert not np.any(early["contact.active"][other])
    # on the grid, the state is the FMI 2.0 FMU's to the bit
    rows = np.flatnonzero(on_grid)
    assert len(rows) == len(grid)
    for name in ("structure.x", "structure.v", "ice.z", "ice.v", "contact.count",
                 "contact.active", "contact.t_last"):
        assert np.array_equal(early[name][rows], grid[name]), name
    # and each grid step's impulse is split among its early returns, to rounding
    split = np.zeros(len(grid))
    step = np.searchsorted(grid["time"], times, side="left")
    np.add.at(split, step[1:], early["contact.impulse"][1:])
    assert np.allclose(split[1:], grid["contact.impulse"][1:], rtol=1e-12, atol=1e-12)


def test_event_mode_adds_one_sample_after_each_event_and_changes_nothing(fmu3):
    options = dict(stop_time=10.0, output_interval=1e-2, start_values=SCENES["plastic, sticking"],
                   early_return_allowed=True)
    plain = simulate_fmu(str(fmu3), **options)
    events = simulate_fmu(str(fmu3), use_event_mode=True, **options)
    early_times = plain["time"][~np.isclose(plain["time"] / 1e-2,
                                            np.round(plain["time"] / 1e-2), atol=1e-9)]
    assert len(events) == len(plain) + len(early_times)
    # FMPy samples once after the step and once after event mode: the same values
    _, first = np.unique(events["time"], return_index=True)
    for name in plain.dtype.names:
        assert np.array_equal(events[name][first], plain[name]), name


# Stepping by hand: event mode's state machine, the FMU state, refusals ---------------------------
class Slave:
    """An IceImpact3.fmu instance in FMPy that keeps its log (logging on, unless
    ``loggingOn=False`` is given) and returns statuses."""

    def __init__(self, fmu_dir: str, **instantiate):
        md = read_model_description(fmu_dir)
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.messages: list[tuple[int, str]] = []

        def log(env, status, category, message):
            self.messages.append((status, message.decode()))

        self.fmu = FMU3Slave(guid=md.guid, unzipDirectory=fmu_dir,
                             modelIdentifier=md.coSimulation.modelIdentifier,
                             instanceName="test")
        self.fmu.instantiate(logMessage=log, **{"loggingOn": True, **instantiate})

    def call(self, name: str, *args):
        try:
            return 0, getattr(self.fmu, name)(*args)
        except FMICallException as exc:
            return exc.status, None

    def start(self, **values):
        self.fmu.enterInitializationMode(startTime=0.0)
        for name, value in values.items():
            self.fmu.setFloat64([self.vr[name]], [value])
        self.fmu.exitInitializationMode()

    def get(self, *names):
        return self.fmu.getFloat64([self.vr[n] for n in names])

    def close(self):
        self.fmu.terminate()
        self.fmu.freeInstance()


@pytest.fixture(scope="module")
def fmu3_x(fmu3, tmp_path_factory):
    return extract(str(fmu3), unzipdir=str(tmp_path_factory.mktemp("fmu3_x")))


def test_event_mode_follows_the_state_machine(fmu3_x):
    slave = Slave(fmu3_x, eventModeUsed=True, earlyReturnAllowed=True)
    slave.start()
    # after initialization: Event Mode, until fmi3EnterStepMode
    assert slave.call("doStep", 0.0, 1.0)[0] == ERROR
    assert "Event Mode" in slave.messages[-1][1]
    assert slave.call("updateDiscreteStates")[0] == 0
    assert slave.call("enterStepMode")[0] == 0
    assert slave.call("enterStepMode")[0] == ERROR
    assert slave.call("updateDiscreteStates")[0] == ERROR
    status, (event, terminate, early, last) = slave.call("doStep", 0.0, 1.0)
    assert (status, event, terminate, early) == (0, True, False, True)
    assert last == _core_impacts({}, 1.0, 1.0)[0]  # the default scene's first impact
    assert slave.call("enterEventMode")[0] == 0
    assert slave.call("enterStepMode")[0] == 0
    status, (event, _, early, t) = slave.call("doStep", last, 1.2 - last)
    assert (event, early, t) == (True, True, _core_impacts({}, 1.2, 1.2)[1])  # the second
    slave.close()


def test_without_event_mode_there_is_no_event_mode(fmu3_x):
    slave = Slave(fmu3_x, earlyReturnAllowed=True)
    slave.start()
    status, (event, _, early, _) = slave.call("doStep", 0.0, 1.0)
    assert (status, event, early) == (0, False, True)
    assert slave.call("enterEventMode")[0] == ERROR
    assert "eventModeUsed = false" in slave.messages[-1][1]
    slave.close()


def test_without_early_return_a_step_contains_its_impacts(fmu3_x):
    slave = Slave(fmu3_x)
    slave.start()
    status, (event, _, early, last) = slave.call("doStep", 0.0, 1.2)
    assert (status, event, early, last) == (0, False, False, 1.2)
    assert slave.fmu.getInt32([slave.vr["contact.count"]]) == [2]  # impacts at 0.89, 1.01 s
    assert slave.get("time") == [1.2]  # the independent variable: the instance's time
    slave.close()


def test_a_state_set_back_repeats_the_run_and_a_serialized_one_too(fmu3_x):
    slave = Slave(fmu3_x, earlyReturnAllowed=True)
    slave.start(**{"impact.e": 0.5})
    slave.fmu.doStep(0.0, 0.5)
    state = slave.fmu.getFMUState()
    blob = slave.fmu.serializeFMUState(state)

    def run_on():
        t, out = 0.5, []
        while t < 3.0:
            _, _, _, t = slave.fmu.doStep(t, 3.0 - t)
            out.append((t, *slave.get("structure.x", "ice.v", "contact.impulse")))
        return out

    first = run_on()
    slave.fmu.setFMUState(state)
    assert run_on() == first
    restored = slave.fmu.deserializeFMUState(blob)
    slave.fmu.setFMUState(restored)
    assert run_on() == first
    assert len(first) > 2  # returned early at impacts
    slave.fmu.freeFMUState(state)
    slave.fmu.freeFMUState(restored)
    # bytes that are no state are refused, and the instance is unchanged
    status, _ = slave.call("deserializeFMUState", b"not a state at all")
    if status == 0:
        status, _ = slave.call("setFMUState", _)
    assert status == ERROR
    assert "refused" in slave.messages[-1][1]
    slave.close()


def test_refusals_have_the_fmi2_messages_and_fmi3_statuses(fmu3_x):
    slave = Slave(fmu3_x)
    slave.fmu.enterInitializationMode(startTime=0.0)
    slave.fmu.setFloat64([slave.vr["structure.m"]], [-1.0])
    slave.fmu.exitInitializationMode()
    assert slave.call("doStep", 0.0, 0.01)[0] == ERROR
    assert "structure.m = -1.0 is not allowed" in " ".join(m for _, m in slave.messages)
    slave.close()
    slave = Slave(fmu3_x)
    slave.start()
    assert slave.call("doStep", 0.0, 0.0)[0] == DISCARD  # a step size that is not > 0
    assert "communication step size = 0.0 s is not allowed" in slave.messages[-1][1]
    assert slave.call("doStep", 0.5, 0.01)[0] == DISCARD  # not the FMU's time
    assert slave.call("getFloat64", [10**6])[0] == ERROR
    assert "value reference = 1000000 is not allowed" in slave.messages[-1][1]
    assert slave.call("getInt64", [0])[0] == ERROR
    assert "has no Int64 variables" in slave.messages[-1][1]
    assert slave.call("setFloat64", [slave.vr["structure.x"]], [1.0])[0] == ERROR
    assert slave.call("getDirectionalDerivative", [0], [1], [1.0])[0] == ERROR
    # the instance goes on stepping
    assert slave.call("doStep", 0.0, 0.01)[0] == 0
    slave.close()


def test_model_exchange_is_refused_with_a_message(fmu3_x):
    md = read_model_description(fmu3_x)
    messages = []
    fmu = FMU3Slave(guid=md.guid, unzipDirectory=fmu3_x, modelIdentifier="IceImpact3",
                    instanceName="me")
    from fmpy.fmi3 import fmi3LogMessageCallback

    callback = fmi3LogMessageCallback(lambda env, status, category, message:
                                      messages.append(message.decode()))
    component = fmu.fmi3InstantiateModelExchange(b"me", md.guid.encode(), c_char_p(None), False,
                                                 True, None, callback)
    assert not component
    assert "Co-Simulation FMU only" in messages[0]


def test_with_logging_off_the_fmu_never_calls_the_logger_and_says_errors_on_stderr(fmu3_x,
                                                                                   capfd):
    """FMI 3.0: with loggingOn = false the FMU does not call logMessage, not even for the
    intermediate variables it ignores or a refused call; those go to stderr (as the reason of a
    failed start does). fmi3SetDebugLogging turns the logger on and off."""
    md = read_model_description(fmu3_x)
    calls = []

    def log(env, status, category, message):
        calls.append(message.decode())

    fmu = FMU3Slave(guid=md.guid, unzipDirectory=fmu3_x,
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="quiet")
    fmu.instantiate(loggingOn=False, logMessage=log, eventModeUsed=True,
                    requiredIntermediateVariables=[1, 2])
    assert "the 2 required are ignored" in capfd.readouterr().err
    try:
        fmu.enterInitializationMode(startTime=0.0)
        fmu.exitInitializationMode()
        try:  # in Event Mode: refused
            fmu.doStep(0.0, 1.0)
        except Exception:
            pass
        assert calls == []
        assert "in Event Mode" in capfd.readouterr().err
        fmu.setDebugLogging(True, [])
        try:
            fmu.doStep(0.0, 1.0)
        except Exception:
            pass
        assert any("Event Mode" in c for c in calls)
    finally:
        fmu.terminate()
        fmu.freeInstance()
