"""The extremes at the FMU: the matrix of tests/extremes.py through FMPy, and bad input everywhere.

Each corner scene runs through one hand-stepped FMU instance per drag law and method (fmi2Reset
between scenes), with the flow reversals set on the input ``flow.u``. Its outputs must equal the
core stepped alike, stay finite, and keep ``contact.gap`` and ``contact.penetration`` >= 0.

Bad values of every parameter before initialization, and of the tunable ``impact.e`` and the input
``flow.u`` during the run, must give a non-OK status, a log message naming the variable, its value
and the allowed range, outputs that stay finite, further calls that are refused the same way, and
an instance that can still be reset, re-initialized and freed.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from extremes import CELLS, fmi_values, scene_of
from fmu_host import (
    FMI_DISCARD,
    FMI_ERROR,
    FMI_OK,
    OUTPUTS,
    REAL_OUTPUTS,
    Instance,
    assert_outputs_finite,
    errors,
)
from iceimpact import ParameterError, Scene, Simulator
from iceimpact.contract import INT32_MAX
from iceimpact.scene import FLOW_INPUT, PARAMETERS

#: At the FMU a cell runs at most this many communication steps (the flow reversals included):
#: the FMU adds ~60 us per step to the core, and equality with the core is what is checked here.
FMU_MAX_STEPS = 1500


def _plan(cell, method: int):
    """(h, u) of every communication step of the cell at the FMU."""
    t_end = cell.t_end if method != 3 or cell.t_end_ode is None else cell.t_end_ode
    flow = [(0.0, cell.changes.get("flow_u", Scene().flow_u)), *cell.flow]
    h = cell.h
    if cell.flow:  # keep the reversals: fewer, longer steps
        h = max(h, t_end / FMU_MAX_STEPS)
    steps = []
    for k in range(min(round(t_end / h), FMU_MAX_STEPS)):
        t = k * h
        steps.append(((k + 1) * h - t, [u for since, u in flow if since <= t + 1e-12][-1]))
    return steps


@pytest.mark.parametrize("method", [1, 2, 3], ids=["exact", "fixed-step", "ode"])
@pytest.mark.parametrize("drag", [1, 2], ids=["linear", "quadratic"])
def test_extremes_matrix_through_the_fmu(fmu_dir, model_description, drag, method):
    inst = Instance(fmu_dir, model_description)
    checked = refused = 0
    try:
        for cell in CELLS:
            if method == 3 and cell.t_end_ode == 0.0:
                continue  # too costly for method 3 (see tests/extremes.py)
            if (drag, method) in cell.refused:
                # not supported by this method: the run is refused (fmi2Error) with a message
                # naming the parameter, outputs finite
                inst.fmu.reset()
                inst.messages.clear()
                inst.initialize(fmi_values(cell, drag, method))
                assert inst.step(0.0, 1e-3) == FMI_ERROR, cell.name
                assert "structure.Cd = 1.0 is not allowed" in errors(inst), errors(inst)
                assert_outputs_finite(inst)
                inst.messages.clear()
                refused += 1
                continue
            scene = scene_of(cell, drag, method)
            plan = _plan(cell, method)
            values = scene.to_fmi()
            inst.fmu.reset()
            assert inst.initialize(values) == FMI_OK
            sim = Simulator(scene)
            t = 0.0
            for h, u in plan:
                inst.set({FLOW_INPUT.name: u})
                assert inst.step(t, h) == FMI_OK, (cell.name, errors(inst))
                t += h
                expected = sim.advance(h, u)
                out = inst.outputs()
                for o in OUTPUTS:
                    want = getattr(expected, o.field)
                    if o.name == "contact.t_last":
                        want = want if want >= 0.0 else -1.0
                    assert out[o.name] == (o.kind(want) if o.kind is not float else
                                           pytest.approx(want, rel=0, abs=1e-12)), (
                        cell.name, o.name, t)
                assert all(math.isfinite(out[o.name]) for o in REAL_OUTPUTS), cell.name
                assert out["contact.gap"] >= 0.0 and out["contact.penetration"] >= 0.0
                if method == 1:
                    assert out["contact.penetration"] == 0.0, cell.name
                # (docs/explanation/morison.md)
                if method == 3 and (drag, method) not in cell.known:
                    assert out["contact.penetration"] <= 10 * 1e-3 * scene.solver_rtol, cell.name
            checked += 1
    finally:
        inst.free()
    assert checked + refused >= len(CELLS) - 1
    assert refused == sum((drag, method) in c.refused for c in CELLS)
    assert not errors(inst)


# Bad values of every parameter before initialization --------------------------------------------
def _bad_values(spec) -> list:
    """NaN, +-inf, zero, negative and out-of-range values for one parameter (integers: zero,
    negative and out of range)."""
    if spec.kind is int:
        # (one above solver.max_impacts' maximum is no fmi2Integer: it wraps to -2^31, refused)
        return [0, -1, int(spec.maximum) + 1 if spec.maximum < INT32_MAX else -INT32_MAX - 1]
    values = [math.nan, math.inf, -math.inf, 0.0, -1.0]
    if spec.maximum is not None:
        values.append(spec.maximum + 1.0)
    if spec.minimum is not None and spec.minimum > 0.0:
        values.append(spec.minimum / 10)
    return values


@pytest.mark.parametrize("spec", PARAMETERS, ids=[p.name for p in PARAMETERS])
def test_every_bad_parameter_value_is_reported_before_initialization(fmu_dir, model_description,
                                                                     spec):
    """Values the core refuses give an error log naming variable, value and range, and doStep
    is refused (fmi2Error) until fmi2Reset; values it accepts (zero or negative x0, v0, ...)
    run. Either way the outputs stay finite and the instance can be reset and freed."""
    inst = Instance(fmu_dir, model_description)
    try:
        for value in _bad_values(spec):
            inst.fmu.reset()
            inst.messages.clear()
            try:
                Scene.from_fmi({spec.name: value})
            except ParameterError as exc:
                expected = str(exc)
            else:
                expected = None
            inst.initialize({spec.name: value})
            status = inst.step(0.0, 1e-3)
            assert_outputs_finite(inst)
            if expected is None:
                assert status == FMI_OK, (spec.name, value, errors(inst))
                continue
            # the message names the parameter, or the combination it breaks (x0 < 0 puts the
            # default ice.z0 downstream)
            assert spec.name in expected
            assert expected in errors(inst), (spec.name, value, errors(inst))
            assert status == FMI_ERROR
            # a call after the error: refused again with the same reason, nothing changes
            before = inst.outputs()
            assert inst.step(0.0, 1e-3) == FMI_ERROR
            assert errors(inst).count(expected) >= 2
            assert inst.outputs() == before
        # after all that, a valid initialization runs normally
        inst.fmu.reset()
        inst.messages.clear()
        inst.initialize({})
        assert inst.step(0.0, 1e-3) == FMI_OK and not errors(inst)
        inst.fmu.terminate()
    finally:
        inst.free()


# Bad values of the tunable parameter and the input during the run ------------------------------
BAD_DURING_RUN = (
    [("impact.e", v, "impact.e = {!r} is not allowed: 0 <= e <= 1")
     for v in (math.nan, math.inf, -math.inf, -0.5, 1.5)]
    + [("flow.u", v, "flow.u = {!r} is not allowed: a finite real number (m/s)")
       for v in (math.nan, math.inf, -math.inf)]
    + [("flow.u", 1e200, "flow.u = {!r} is not allowed: a flow speed whose drag force")]
)


@pytest.mark.parametrize("method", [1, 2, 3], ids=["exact", "fixed-step", "ode"])
def test_bad_tunable_and_input_values_during_the_run(fmu_dir, model_description, method):
    """Each bad value set mid-run: doStep returns fmi2Discard with a message naming it, outputs
    keep their last valid (finite) values, a second call is refused the same way, and once a valid
    value is set the run goes on exactly like a core run that never saw the bad value."""
    values = {"drag.model": 2, "solver.method": method, "solver.detection": 2}
    inst = Instance(fmu_dir, model_description)
    try:
        for name, bad, message in BAD_DURING_RUN:
            inst.fmu.reset()
            inst.messages.clear()
            inst.initialize(values)
            inst.run(200)
            before = inst.outputs()
            inst.set({name: bad})
            for _ in range(2):  # the call after an error is refused too
                assert inst.step(0.2, 1e-3) == FMI_DISCARD, (name, bad)
                assert message.format(bad) in errors(inst), (name, bad, errors(inst))
                assert inst.outputs() == before
            good = 0.5 if name == "impact.e" else -0.1  # zero and negative flows are valid
            inst.set({name: good})
            rows = inst.run(300, start_index=200)
            # the core, stepped alike, with the valid value from t = 0.2 s on
            sim = Simulator(Scene.from_fmi(values))
            for k in range(200):
                sim.advance((k + 1) * 1e-3 - k * 1e-3)
            u = None
            if name == "impact.e":
                sim.set_restitution(good)
            else:
                u = good
            for k, row in enumerate(rows, start=200):
                want = sim.advance((k + 1) * 1e-3 - k * 1e-3, u)
                assert row["structure.x"] == pytest.approx(want.x, rel=0, abs=1e-12)
                assert row["ice.z"] == pytest.approx(want.z, rel=0, abs=1e-12)
                assert row["contact.count"] == want.impact_count
            assert all(np.isfinite([r[o.name] for r in rows for o in REAL_OUTPUTS]))
        inst.fmu.terminate()
    finally:
        inst.free()


def test_zero_flow_and_plastic_impacts_set_during_the_run_are_valid(fmu_dir, model_description):
    """The edges of the allowed ranges (u = 0, e = 0, e = 1) are accepted mid-run."""
    inst = Instance(fmu_dir, model_description)
    try:
        inst.initialize({})
        inst.run(100)
        for k, (name, value) in enumerate((("flow.u", 0.0), ("impact.e", 0.0),
                                           ("impact.e", 1.0))):
            inst.set({name: value})
            t = (100 + k) * 1e-3
            assert inst.step(t, (101 + k) * 1e-3 - t) == FMI_OK, errors(inst)
            assert_outputs_finite(inst)
    finally:
        inst.free()
    assert not errors(inst)


def test_a_run_the_method_cannot_continue_is_stopped_and_stays_stopped(fmu_dir,
                                                                       model_description):
    """Method 2's explicit Euler step diverging after an impact: fmi2Discard with the reason,
    outputs finite and unchanged, every later doStep refused the same way; reset recovers."""
    from scenes import EULER_DIVERGES_AFTER_IMPACT

    values = Scene(**EULER_DIVERGES_AFTER_IMPACT).to_fmi()
    inst = Instance(fmu_dir, model_description)
    try:
        assert inst.initialize(values) == FMI_OK
        t, status = 0.0, FMI_OK
        for _ in range(100):
            status = inst.step(t, 1e-3)
            if status != FMI_OK:
                break
            t += 1e-3
        assert status == FMI_DISCARD
        assert "too large for the explicit Euler step of the quadratic drag" in errors(inst)
        before = inst.outputs()
        assert_outputs_finite(inst)
        assert inst.step(t, 1e-3) == FMI_DISCARD
        assert errors(inst).count("the run stopped") >= 2
        assert inst.outputs() == before
        inst.fmu.reset()
        assert inst.initialize({**values, "solver.method": 1}) == FMI_OK
        assert inst.step(0.0, 0.1) == FMI_OK
    finally:
        inst.free()
