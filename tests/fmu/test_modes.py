"""The modal structure (structure.model = 3) through IceImpact.fmu and IceImpact3.fmu in FMPy.

A two-mode scene gives the core's numbers to the bit (iceimpact.run's x and impact count, the
modal q and v of Simulator stepped like the master, structure.force = k_c x), in FMI 2.0 and
FMI 3.0, with early return too; the load inputs drive the modes (a constant load settles mode 1
at its static offset L / k); a bad mode value is refused with a message naming it and the
instance survives; an FMI 3.0 state taken while the ice rides continues identically, set back or
deserialized.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from fmpy import simulate_fmu

from fmu_host import FMI_ERROR, FMI_OK, Instance, assert_outputs_finite, errors
from iceimpact import Scene, Simulator, run
from iceimpact.contract import BY_NAME, MAX_MODES

#: Two modes seen at the contact point, quadratic drag, restitution 0.7: impacts every second.
TWO_MODES = {"structure.model": 3, "structure.modes": 2, "structure.mode2.f": 11.0,
             "structure.mode2.zeta": 0.02, "structure.mode2.phi": 0.6, "drag.model": 2,
             "flow.u": 0.3, "ice.M": 1200.0, "impact.e": 0.7}
H, T_END = 1e-2, 5.0
MODE_OUTPUTS = [f"structure.mode{k}.{q}" for k in range(1, MAX_MODES + 1) for q in "qv"]


def scene_of(values: dict) -> Scene:
    return Scene.from_fmi(values)


def stepped(values: dict, t_end: float, h: float, loads=None) -> list:
    """The core's reports on FMPy's grid k*h (``loads(t)``: the modes' loads held over the step
    from t)."""
    sim = Simulator(scene_of(values))
    reports = [sim.report]
    for k in range(round(t_end / h)):
        t = k * h
        reports.append(sim.advance((k + 1) * h - t, loads=None if loads is None else loads(t)))
    return reports


@pytest.fixture(scope="module")
def grid(fmu):
    return simulate_fmu(str(fmu), stop_time=T_END, output_interval=H, start_values=TWO_MODES)


@pytest.mark.parametrize("which", ["FMI 2.0", "FMI 3.0"])
def test_two_modes_give_the_core_numbers_to_the_bit(which, fmu, fmu3, grid):
    result = grid if which == "FMI 2.0" else simulate_fmu(
        str(fmu3), stop_time=T_END, output_interval=H, start_values=TWO_MODES)
    core = run(scene_of(TWO_MODES), T_END, dt=H)
    assert np.array_equal(result["time"], core.t)
    assert np.array_equal(result["structure.x"], core.x)
    assert np.array_equal(result["ice.z"], core.z)
    assert result["contact.count"][-1] == len(core.impacts) > 10
    reports = stepped(TWO_MODES, T_END, H)
    for name in MODE_OUTPUTS:
        k, q = name.split(".")[1][4:], name[-1]
        expected = np.array([getattr(r, f"mode{k}_{q}") for r in reports])
        assert np.array_equal(result[name], expected), name
    # both modes move, the unused ones stay at 0
    for k in (1, 2):
        assert np.ptp(result[f"structure.mode{k}.q"]) > 0.0, k
    for k in range(3, MAX_MODES + 1):
        assert not result[f"structure.mode{k}.q"].any() and not result[f"structure.mode{k}.v"].any()
    # the contact point is the modes' sum phi q, to rounding
    x = result["structure.mode1.q"] + 0.6 * result["structure.mode2.q"]
    np.testing.assert_allclose(result["structure.x"], x, rtol=0.0, atol=1e-15)
    # structure.force is k_c x: the static stiffness at the contact point, here worked out from
    # the modes (mode 1 Figure 2's SDOF, k = 1e6 N/m; mode 2 1600 kg at 11 Hz, seen at 0.6)
    k_c = 1.0 / (1.0 / 1.0e6 + 0.36 / (1600.0 * (22.0 * math.pi) ** 2))
    assert np.ptp(result["structure.force"]) > 0.0
    np.testing.assert_allclose(result["structure.force"], k_c * result["structure.x"],
                               rtol=1e-14, atol=0.0)
    assert np.array_equal(result["structure.force"], [r.spring_force for r in reports])


def test_fmi3_early_return_gives_the_same_numbers_on_the_grid(fmu3, grid):
    early = simulate_fmu(str(fmu3), stop_time=T_END, output_interval=H, start_values=TWO_MODES,
                         early_return_allowed=True)
    sim = Simulator(scene_of(TWO_MODES))
    for k in range(round(T_END / H)):
        sim.advance_to((k + 1) * H)
    impacts = [impact.t for impact in sim.impacts]
    times = early["time"]
    assert len(times) > len(grid["time"]) and set(impacts) <= set(times.tolist())
    rows = np.flatnonzero(np.isin(times, grid["time"]))
    assert len(rows) == len(grid)
    for name in ("structure.x", "structure.v", "ice.z", "ice.v", "contact.count",
                 "contact.t_last", *MODE_OUTPUTS):
        assert np.array_equal(early[name][rows], grid[name]), name


#: The ice at rest far upstream (no contact): the loads alone drive the structure.
LOADED = {"structure.model": 3, "structure.modes": 2, "structure.mode1.zeta": 0.2,
          "structure.mode2.f": 11.0,
          "structure.mode2.zeta": 0.02, "structure.mode2.phi": 0.6, "flow.u": 0.0,
          "ice.v0": 0.0, "ice.z0": -1.0}
LOAD, T_LOADED = 5000.0, 6.0


def test_a_load_input_table_drives_mode_1_to_its_static_offset(fmu, fmu3):
    """A constant load from an FMPy input table, the structure at rest at the start: the same
    numbers as Simulator.advance(..., loads=(L, 0)), and mode 1 at L / k after the transient."""
    # one row, which FMPy holds (two equal rows would be interpolated, off by rounding)
    signal = np.zeros(1, dtype=[("time", float), ("structure.mode1.load", float)])
    signal["time"], signal["structure.mode1.load"] = 0.0, LOAD
    reports = stepped(LOADED, T_LOADED, H, loads=lambda t: (LOAD, 0.0))
    scene = scene_of(LOADED)
    stiffness = scene.structure_mode1_m * (2.0 * math.pi * scene.structure_mode1_f) ** 2
    unloaded = simulate_fmu(str(fmu), stop_time=1.0, output_interval=H, start_values=LOADED)
    assert not unloaded["structure.x"].any()  # without the load nothing moves
    for path in (fmu, fmu3):
        result = simulate_fmu(str(path), stop_time=T_LOADED, output_interval=H,
                              start_values=LOADED, input=signal)
        for name in ("structure.x", "structure.v", *MODE_OUTPUTS):
            k, q = (name.split(".")[1][4:], name[-1]) if "mode" in name else (None, None)
            field = f"mode{k}_{q}" if k else name.split(".")[1]
            expected = np.array([getattr(r, field) for r in reports])
            assert np.array_equal(result[name], expected), (path.name, name)
        q1 = result["structure.mode1.q"]
        # overshoot first, then (zeta = 0.2 at 4 Hz: e^-30 in 6 s) the static offset L / k
        assert q1.max() > 1.4 * LOAD / stiffness
        assert q1[-1] == pytest.approx(LOAD / stiffness, rel=1e-9)
        assert result["structure.x"][-1] == pytest.approx(LOAD / stiffness, rel=1e-9)
        assert not result["structure.mode2.q"].any()  # mode 2 has no load and no contact
        assert result["contact.count"][-1] == 0


@pytest.mark.parametrize(("values", "message"), [
    ({"structure.mode1.m": -1.0}, "structure.mode1.m = -1.0 is not allowed: > 0"),
    ({"structure.modes": 2, "structure.mode1.phi": 0.0},
     "structure.mode1.phi = 0.0 is not allowed: not 0 for at least one of the 2 modes used"),
    ({"structure.modes": 6}, "structure.modes = 6 is not allowed: 1 <= modes <= 5"),
    ({"structure.mode2.f": 0.0, "structure.modes": 2},
     "structure.mode2.f = 0.0 is not allowed: > 0"),
    ({"structure.Cd": 1.0, "structure.A": 2.0},
     "Morison loads on the modal structure are not modelled"),
])
def test_a_bad_mode_value_is_reported_and_the_instance_survives(fmu_dir, model_description,
                                                               values, message):
    inst = Instance(fmu_dir, model_description)
    try:
        assert inst.initialize({"structure.model": 3} | values) == FMI_OK
        assert message in errors(inst)
        assert any(s == FMI_ERROR for s, _, _ in inst.messages)
        assert inst.step(0.0, H) == FMI_ERROR
        assert_outputs_finite(inst)
        inst.fmu.reset()  # the same instance then runs a good modal scene
        inst.messages.clear()
        assert inst.initialize(TWO_MODES) == FMI_OK
        rows = inst.run(50)
    finally:
        inst.free()
    assert not errors(inst)
    reports = stepped(TWO_MODES, 50 * 1e-3, 1e-3)
    assert rows[-1]["structure.x"] == reports[-1].x
    assert rows[-1]["structure.mode2.q"] == reports[-1].mode2_q


def test_the_load_inputs_are_continuous_real_inputs(model_description):
    variables = {v.name: v for v in model_description.modelVariables}
    for k in range(1, MAX_MODES + 1):
        v = variables[f"structure.mode{k}.load"]
        assert (v.causality, v.variability, v.type, v.unit) == ("input", "continuous", "Real",
                                                                "N")
        assert BY_NAME[v.name].start == float(v.start) == 0.0


def test_fmi3_state_of_the_riding_ice_set_back_and_deserialized_continues_identically(fmu3_dir):
    from fmpy import read_model_description
    from fmpy.fmi3 import FMU3Slave

    md = read_model_description(fmu3_dir)
    variables = {v.name: v for v in md.modelVariables}
    fmu = FMU3Slave(guid=md.guid, unzipDirectory=fmu3_dir,
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="modal")
    fmu.instantiate()
    values = TWO_MODES | {"impact.e": 0.0}  # plastic: the ice rides from ~0.53 s
    names = ("structure.x", "ice.z", "contact.impulse", "structure.mode1.q",
             "structure.mode2.v")

    def get() -> tuple:
        return (*fmu.getFloat64([variables[n].valueReference for n in names]),
                *fmu.getBoolean([variables["contact.active"].valueReference]))

    def run_on(k0: int, loads: tuple[float, float], n: int = 80) -> list[tuple]:
        fmu.setFloat64([variables[f"structure.mode{k}.load"].valueReference for k in (1, 2)],
                       list(loads))
        out = []
        for k in range(k0, k0 + n):
            fmu.doStep(k * H, (k + 1) * H - k * H)
            out.append(get())
        return out

    try:
        fmu.enterInitializationMode(startTime=0.0)
        for name, value in values.items():
            if variables[name].type == "Int32":
                fmu.setInt32([variables[name].valueReference], [value])
            else:
                fmu.setFloat64([variables[name].valueReference], [value])
        fmu.exitInitializationMode()
        run_on(0, (0.0, 0.0), 60)
        assert get()[-1]  # riding at 0.6 s
        state = fmu.getFMUState()
        blob = fmu.serializeFMUState(state)
        first = run_on(60, (300.0, -120.0))
        fmu.setFMUState(state)
        assert run_on(60, (300.0, -120.0)) == first
        restored = fmu.deserializeFMUState(blob)
        fmu.setFMUState(restored)
        assert run_on(60, (300.0, -120.0)) == first
        fmu.freeFMUState(state)
        fmu.freeFMUState(restored)
    finally:
        fmu.terminate()
        fmu.freeInstance()
    sim = Simulator(scene_of(values))
    for k in range(140):
        sim.advance((k + 1) * H - k * H, loads=(300.0, -120.0) if k >= 60 else (0.0, 0.0))
    assert first[-1][0] == sim.report.x and first[-1][4] == sim.report.mode2_v


def test_load_order_1_continues_each_load_at_its_last_rate(fmu, fmu3):
    """structure.load_order = 1 with a ramp from an FMPy input table (FMPy interpolates it, so
    the load at each step's start is the ramp's): each step continues the load at its rate
    between the last two communication points, as Simulator.advance(..., loads, load_rates)
    does; the first step holds. A ramp is then followed exactly (from the second step on),
    where a held load lags it."""
    rate = 20000.0  # N/s
    signal = np.zeros(2, dtype=[("time", float), ("structure.mode1.load", float)])
    signal["time"], signal["structure.mode1.load"] = (0.0, 10.0), (0.0, 10.0 * rate)
    values = LOADED | {"structure.load_order": 1}
    sim = Simulator(scene_of(values))
    expected = [sim.report.x]
    for k in range(round(2.0 / H)):
        t = k * H
        sim.advance((k + 1) * H - t, loads=(rate * t, 0.0),
                    load_rates=(rate if k > 0 else 0.0, 0.0))
        expected.append(sim.report.x)
    held = stepped(LOADED, 2.0, H, loads=lambda t: (rate * t, 0.0))
    for path in (fmu, fmu3):
        result = simulate_fmu(str(path), stop_time=2.0, output_interval=H, start_values=values,
                              input=signal)
        np.testing.assert_allclose(result["structure.x"], expected, rtol=1e-12, atol=1e-18)
        assert not np.array_equal(result["structure.x"], [r.x for r in held])
