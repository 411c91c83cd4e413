"""fmi2Get and fmi2Set of IceImpact.fmu: the slave's batch tables against PythonFMU's own path.

The slave (``iceimpact.fmi.slave_base.FmuSlave``) answers fmi2Get of outputs from the model's
published row through a value-reference table made from the contract, and fmi2Set through a
table of the parameters and inputs. Checked here:

- in the process, against PythonFMU's default ``Fmi2Slave.get_*`` (one registered getter per
  variable, the path the slave replaces): the same values, of the same Python types, for every
  variable, in every FMI state (instantiated, parameters set, initialization mode, initialized,
  after steps, a tunable pending, a fixed parameter refused, a state set back, a refused step);
- through FMPy, against an independent reference (the contract's start values, the values set,
  the core :class:`~iceimpact.Simulator` stepped alike): every variable read in one call per type
  (outputs only: the table; with a parameter in front: variable by variable) and alone;
- a value reference that is not a variable of the call's type (or, for fmi2Set, an output) makes
  the call return fmi2Error with a message naming it; nothing is set and the instance goes on.
"""

from __future__ import annotations

import math

import pytest
from fmpy.fmi1 import FMICallException
from pythonfmu import Fmi2Slave

from fmu_host import DT, FMI_ERROR, FMI_OK, Instance, errors
from IceImpact import IceImpact
from iceimpact import Scene, Simulator
from iceimpact.contract import INPUTS, OUTPUTS, PARAMETERS, VARIABLES
from iceimpact.fmi.adapter import FmuModel

KINDS = (float, int, bool)
DEFAULT_GET = {float: Fmi2Slave.get_real, int: Fmi2Slave.get_integer, bool: Fmi2Slave.get_boolean}
# The slave's value references: the contract's variables in order (the registration order).
VR = {v.name: vr for vr, v in enumerate(VARIABLES)}
VALUES = {"ice.M": 2400.0, "impact.e": 0.5, "solver.method": 1, "structure.x0": 1e-3}


# In the process: the batch path against PythonFMU's default one ---------------------------------
def assert_batch_equals_default(slave: IceImpact) -> dict[str, object]:
    """Every variable through the slave's get_* (all of a type at once, outputs alone, each
    variable alone) equals PythonFMU's default get_* (value and type); returns the values."""
    values: dict[str, object] = {}
    for kind in KINDS:
        get = {float: slave.get_real, int: slave.get_integer, bool: slave.get_boolean}[kind]
        names = [v.name for v in VARIABLES if v.kind is kind]
        outputs = [o.name for o in OUTPUTS if o.kind is kind]
        vrs = [VR[n] for n in names]
        default = DEFAULT_GET[kind](slave, vrs)
        batch = get(vrs)
        assert batch == default and [type(x) for x in batch] == [type(x) for x in default], kind
        fast = get([VR[n] for n in outputs])  # the published row through the table
        assert fast == DEFAULT_GET[kind](slave, [VR[n] for n in outputs])
        assert [type(x) for x in fast] == [kind] * len(outputs), (kind, fast)
        for name, value in zip(names, default, strict=True):
            single = get([VR[name]])
            assert single == [value] and type(single[0]) is type(value), name
            values[name] = value
    assert not [m.msg for m in slave.log_queue if m.status.value >= 2], "a get was refused"
    return values


def test_batch_get_equals_pythonfmu_default_in_every_state():
    slave = IceImpact(instance_name="batch")
    start = {**{p.name: p.start for p in PARAMETERS}, **{i.name: i.start for i in INPUTS}}
    idle = Simulator(Scene()).report
    got = assert_batch_equals_default(slave)  # instantiated
    assert {n: got[n] for n in start} == start
    assert got["structure.x"] == idle.x and got["contact.t_last"] == -1.0

    for name, value in VALUES.items():
        (slave.set_integer if isinstance(value, int) else slave.set_real)([VR[name]], [value])
    slave.set_real([VR["flow.u"]], [0.2])
    got = assert_batch_equals_default(slave)  # parameters set, not yet in effect
    assert {n: got[n] for n in VALUES} == VALUES and got["flow.u"] == 0.2
    assert got["structure.x"] == idle.x  # the outputs stay those of the default scene

    slave.setup_experiment(2.0, None, None)
    slave.enter_initialization_mode()
    assert_batch_equals_default(slave)  # initialization mode
    slave.exit_initialization_mode()
    got = assert_batch_equals_default(slave)  # initialized
    assert got["structure.x"] == VALUES["structure.x0"]

    sim = Simulator(Scene.from_fmi({**VALUES, "flow.u": 0.2}))
    t = 2.0
    for _ in range(3000):  # past the first impacts
        assert slave.do_step(t, DT)
        report = sim.advance(DT, 0.2)
        t += DT
    got = assert_batch_equals_default(slave)
    assert got["contact.count"] == report.impact_count >= 1
    assert got["structure.x"] == report.x and got["contact.active"] == report.sticking
    assert got["contact.t_last"] == report.t_last + 2.0  # in the master's time frame
    state = slave._get_fmu_state()

    slave.set_real([VR["impact.e"]], [0.8])  # tunable: pending until the next step
    got = assert_batch_equals_default(slave)
    assert got["impact.e"] == 0.8
    slave.set_real([VR["structure.m"]], [800.0])  # fixed: refused, the value in use stays
    assert [m.msg for m in slave.log_queue if "structure.m is a fixed parameter" in m.msg]
    slave.log_queue.clear()
    got = assert_batch_equals_default(slave)
    assert got["structure.m"] == 1600.0
    assert slave.do_step(t, DT)
    after = assert_batch_equals_default(slave)
    assert after["impact.e"] == 0.8 and after["structure.x"] != got["structure.x"]

    slave._set_fmu_state(state)  # back to before the tunable
    got = assert_batch_equals_default(slave)
    assert got["impact.e"] == 0.5 and got["structure.x"] == report.x

    assert not slave.do_step(t, -DT)  # a refused step changes no value
    slave.log_queue.clear()
    assert assert_batch_equals_default(slave) == got


def test_set_tables_cover_exactly_the_parameters_and_inputs():
    slave = IceImpact(instance_name="tables")
    settable = {name for kind in KINDS + (str,) for name in slave._settable[kind].values()}
    assert settable == {v.name for v in PARAMETERS + INPUTS}
    published = {vr for kind in KINDS + (str,) for vr in slave._output_slots[kind]}
    assert published == {VR[o.name] for o in OUTPUTS}
    for kind in KINDS:  # each table holds the variables of its FMI type only
        assert all(VARIABLES[vr].kind is kind for vr in slave._settable[kind])
        assert all(VARIABLES[vr].kind is kind for vr in slave._output_slots[kind])


@pytest.mark.parametrize("start_time", [0.0, 2.0, -3.5])
@pytest.mark.parametrize("t_last", [-1.0, 0.0, -0.0, 5e-324, 0.25, 1e300])
def test_published_time_of_the_last_impact_is_in_the_master_time_frame(start_time, t_last):
    model = FmuModel(lambda status, text: None)
    model.setup_experiment(start_time)
    report = Simulator(Scene()).report
    report.__dict__["t_last"] = t_last
    model.publish(report)
    got = model.published[[o.name for o in OUTPUTS].index("contact.t_last")]
    want = t_last + start_time if t_last >= 0.0 else -1.0  # docs/reference/fmu.md: simulation time
    assert got == want and math.copysign(1.0, got) == math.copysign(1.0, want), (got, want)
    assert [model.get(o.name) for o in OUTPUTS] == list(model.published)


# Through FMPy: against an independent reference ---------------------------------------------------
def fmi_values(inst: Instance) -> dict[str, object]:
    """Every variable, by one call per type (outputs alone; then a parameter first, which takes
    every variable of the call the slow way) and by one call per variable; all must agree."""
    getters = {float: inst.fmu.getReal, int: inst.fmu.getInteger, bool: inst.fmu.getBoolean}
    first = {float: "structure.m", int: "drag.model"}
    values: dict[str, object] = {}
    for kind, get in getters.items():
        names = [v.name for v in VARIABLES if v.kind is kind]
        outputs = [o.name for o in OUTPUTS if o.kind is kind]
        everything = get([VR[n] for n in names])
        table = get([VR[n] for n in outputs])
        assert list(table) == [everything[names.index(n)] for n in outputs], kind
        if kind in first:
            slow = get([VR[first[kind]]] + [VR[n] for n in outputs])[1:]
            assert list(slow) == list(table), kind
        for name, value in zip(names, everything, strict=True):
            assert get([VR[name]]) == [value], name
            values[name] = value
    return values


def expected_values(values: dict, report, start_time: float = 0.0) -> dict[str, object]:
    out = {**{p.name: p.start for p in PARAMETERS}, **{i.name: i.start for i in INPUTS},
           **values}
    for o in OUTPUTS:
        out[o.name] = getattr(report, o.field)
    if report.t_last >= 0.0:
        out["contact.t_last"] = report.t_last + start_time
    return out


def test_fmi_get_of_every_variable_matches_the_reference(fmu_dir, model_description):
    inst = Instance(fmu_dir, model_description)
    try:
        assert fmi_values(inst) == expected_values({}, Simulator(Scene()).report)
        inst.fmu.setupExperiment(startTime=0.0)
        inst.set(VALUES)
        assert fmi_values(inst) == expected_values(VALUES, Simulator(Scene()).report)
        inst.fmu.enterInitializationMode()
        inst.fmu.exitInitializationMode()
        sim = Simulator(Scene.from_fmi(VALUES))
        assert fmi_values(inst) == expected_values(VALUES, sim.report)
        for k in range(3000):
            assert inst.step(k * DT, (k + 1) * DT - k * DT) == FMI_OK, errors(inst)
            report = sim.advance((k + 1) * DT - k * DT, 0.1)
        assert report.impact_count >= 1
        assert fmi_values(inst) == expected_values(VALUES, report)
        inst.set({"impact.e": 0.8, "flow.u": 0.15})  # a pending tunable, a new input
        assert fmi_values(inst) == expected_values({**VALUES, "impact.e": 0.8, "flow.u": 0.15},
                                                   report)
        inst.fmu.reset()
        assert fmi_values(inst) == expected_values({}, Simulator(Scene()).report)
    finally:
        inst.free()


# Refusals -----------------------------------------------------------------------------------------
def runs(names: list[str]) -> str:
    """The value references of ``names`` as the messages list them: "0-11, 13, 15-16"."""
    vrs = sorted(VR[n] for n in names)
    starts = [vr for vr in vrs if vr - 1 not in vrs]
    ends = [vr for vr in vrs if vr + 1 not in vrs]
    return ", ".join(f"{a}-{b}" if b > a else f"{a}" for a, b in zip(starts, ends, strict=True))


REALS = [v.name for v in VARIABLES if v.kind is float]
REFUSALS = [
    ("getReal", [999], "fmi2GetReal: value reference = 999 is not allowed: the value reference "
     f"of a Real variable ({runs(REALS)}); nothing is read"),
    ("getReal", [VR["structure.x"], VR["contact.count"]],
     f"fmi2GetReal: value reference = {VR['contact.count']} is not allowed"),
    ("getInteger", [VR["structure.x"]],
     f"; {VR['structure.x']} is structure.x, output, Real; nothing is read"),
    ("getBoolean", [VR["contact.count"]], "the value reference of a Boolean variable "
     f"({VR['contact.active']})"),
    ("getString", [0], "the value reference of a String variable (IceImpact.fmu has none)"),
    ("setReal", [VR["flow.u"], VR["structure.x"]],
     f"fmi2SetReal: value reference = {VR['structure.x']} is not allowed: the value reference of "
     "a Real variable that is a parameter or an input "
     f"({runs([v.name for v in PARAMETERS + INPUTS if v.kind is float])}); "
     f"{VR['structure.x']} is structure.x, output, Real; nothing is set"),
    ("setInteger", [VR["structure.m"]], "fmi2SetInteger: value reference = 0 is not allowed"),
    ("setBoolean", [VR["contact.active"]], "a Boolean variable that is a parameter or an input "
     f"(IceImpact.fmu has none); {VR['contact.active']} is contact.active, output, Boolean"),
]


@pytest.mark.parametrize(("call", "vrs", "message"), REFUSALS,
                         ids=[f"{c}{v}" for c, v, _ in REFUSALS])
def test_a_value_reference_of_another_type_is_refused_cleanly(fmu_dir, model_description, call,
                                                              vrs, message):
    inst = Instance(fmu_dir, model_description)
    try:
        inst.initialize({})
        inst.run(100)
        before = inst.outputs()
        flow = inst.fmu.getReal([VR["flow.u"]])
        args = {"setReal": [0.3] * len(vrs), "setInteger": [2] * len(vrs),
                "setBoolean": [True] * len(vrs)}
        with pytest.raises(FMICallException) as refused:
            if call in args:
                getattr(inst.fmu, call)(vrs, args[call])
            else:
                getattr(inst.fmu, call)(vrs)
        assert refused.value.status == FMI_ERROR
        assert message in errors(inst)
        assert inst.fmu.getReal([VR["flow.u"]]) == flow  # nothing was set
        assert inst.outputs() == before
        rows = inst.run(100, 100)  # the instance goes on
        assert all(math.isfinite(r["structure.x"]) for r in rows)
    finally:
        inst.free()
