"""The FMU state: a small explicit record, a validated versioned blob, and a refused step that
changes nothing; FMI misuse (calls in the wrong state) with defined behaviour.

The blob is outside data: random bytes, truncated and bit-flipped states, other versions and
layouts are refused with an error naming what is wrong, and the instance goes on as before.
"""

from __future__ import annotations

import json
import random

import numpy as np
import pytest
from fmpy.fmi1 import FMICallException

from fmu_host import DT, FMI_DISCARD, FMI_ERROR, FMI_OK, Instance, columns, errors
from iceimpact import Scene, Simulator
from iceimpact.contract import PARAMETERS, VERSION
from iceimpact.fmi import state as fmu_state
from iceimpact.fmi.adapter import TUNERS, FmuModel
from iceimpact.solvers.base import StateError


def model_after(steps: int, values: dict | None = None) -> FmuModel:
    logs: list = []
    model = FmuModel(lambda status, text: logs.append((status, text)))
    for name, value in (values or {}).items():
        model.set(name, value)
    assert model.initialize()
    for k in range(steps):
        assert model.do_step(k * DT, DT), logs
    return model


def valid_blob(steps: int = 1500, values: dict | None = None) -> bytes:
    return fmu_state.encode(model_after(steps, values or {"impact.e": 0.5}).snapshot())


# The layout ---------------------------------------------------------------------------------------
def test_blob_has_the_documented_layout():
    blob = valid_blob()
    assert blob.startswith(b"IceImpact FMU state\n")
    doc = json.loads(blob[len(fmu_state.MAGIC):])
    assert set(doc) == {"format", "fmu_version", "state"}
    assert doc["format"] == fmu_state.FORMAT and doc["fmu_version"] == VERSION
    assert fmu_state.decode(blob) == doc["state"]


def test_every_tunable_parameter_has_a_tuner():
    assert {p.name for p in PARAMETERS if p.tunable} == set(TUNERS)


@pytest.mark.parametrize("values", [{}, {"impact.e": 0.5}, {"drag.model": 2, "impact.e": 0.3},
                                    {"solver.method": 2}, {"solver.method": 3}])
def test_state_size_does_not_grow_with_the_run(values):
    short = len(valid_blob(20, values))
    long = len(valid_blob(6000, values))
    assert long <= 16 * 1024
    assert long < short + 512  # a few digits more at most, no history


# Refusals -----------------------------------------------------------------------------------------
def _refused(blob: bytes, match: str | None = None) -> None:
    with pytest.raises(StateError, match=match):
        fmu_state.decode(blob)


def test_foreign_and_damaged_blobs_are_refused():
    blob = valid_blob()
    _refused(b"", "not a state of IceImpact.fmu")
    _refused(b"\x80\x04\x95" + blob[3:], "not a state of IceImpact.fmu")  # a pickle's start
    _refused(blob[:-1], "damaged")
    _refused(blob[: len(blob) // 2], "damaged")
    _refused(fmu_state.MAGIC + b"\xff\xfe", "damaged")
    _refused(fmu_state.MAGIC + b"x" * (fmu_state.MAX_BYTES + 1), "refused unread")
    _refused(fmu_state.MAGIC + b"[" * 100_000, "refused unread")


def _with(doc_change=None, state_change=None) -> bytes:
    blob = valid_blob(300)
    doc = json.loads(blob[len(fmu_state.MAGIC):])
    if doc_change:
        doc_change(doc)
    if state_change:
        state_change(doc["state"])
    return fmu_state.MAGIC + json.dumps(doc).encode()


def test_other_versions_and_layouts_are_refused():
    _refused(_with(lambda d: d.update(fmu_version="0.2.0")), "fmu_version = '0.2.0' is not allowed")
    _refused(_with(lambda d: d.update(format=2)), "format = 2 is not allowed")
    _refused(_with(lambda d: d.update(extra=1)), "layout")
    _refused(fmu_state.MAGIC + b'{"format": 1, "format": 1}', "appears twice")
    _refused(_with(state_change=lambda s: s.update(time=float("nan"))), "NaN")


@pytest.mark.parametrize(("change", "match"), [
    (lambda s: s.pop("time"), "keys"),
    (lambda s: s.update(time="0.5"), "time = '0.5' is not allowed: a number"),
    (lambda s: s.update(time=True), "time = True is not allowed: a number"),
    (lambda s: s["values"].pop("ice.M"), "every parameter"),
    (lambda s: s["values"].update({"os.system": 1.0}), "every parameter"),
    (lambda s: s["values"].update({"ice.M": [1, 2]}), r"values\['ice.M'\]"),
    (lambda s: s.update(pending={"structure.m": 1.0}), "tunable parameters only"),
    (lambda s: s.update(error=5), "error = 5"),
    (lambda s: s.update(penetration_logged="yes"), "penetration_logged"),
    (lambda s: s.update(simulator=[1]), r"simulator = \[1\] is not allowed: an object"),
])
def test_fields_of_the_wrong_type_are_refused(change, match):
    _refused(_with(state_change=change), match)


def test_simulator_part_is_validated_when_restored():
    """Scene values out of range and malformed solver fields: refused, the model unchanged."""
    blob = valid_blob(300)
    model = model_after(700)
    before = model.snapshot()
    for change in (lambda s: s["simulator"]["scene"].update({"ice.M": -1.0}),
                   lambda s: s["simulator"].pop("scene"),
                   lambda s: s["simulator"].update(solver={"anything": "else"})):
        doc = json.loads(blob[len(fmu_state.MAGIC):])
        change(doc["state"])
        with pytest.raises((StateError, ValueError)):
            model.restore(fmu_state.decode(fmu_state.MAGIC + json.dumps(doc).encode()))
        assert model.snapshot() == before


def test_fuzz_bit_flips_and_truncations_are_refused_or_restore_cleanly():
    """Any change of a valid blob is refused with StateError, or decodes to a record whose
    continuation is finite; never another exception."""
    rng = random.Random(20261123)
    blob = valid_blob(1500)
    counts = {"refused": 0, "restored": 0}
    for trial in range(600):
        data = bytearray(blob)
        if trial % 3 == 0:
            data = data[: rng.randrange(len(data))]
        else:
            for _ in range(rng.randint(1, 4)):
                data[rng.randrange(len(data))] ^= 1 << rng.randrange(8)
        try:
            record = fmu_state.decode(bytes(data))
            model = model_after(0)
            model.restore(record)
        except StateError:
            counts["refused"] += 1
            continue
        except ValueError:  # a ParameterError from the scene inside the record
            counts["refused"] += 1
            continue
        counts["restored"] += 1
        t = model.time
        if model.do_step(t, DT):
            assert np.isfinite([model.get(n) for n in ("structure.x", "ice.z")]).all()
    assert counts["refused"] > 300, counts


def test_random_bytes_are_refused():
    rng = random.Random(7)
    for _ in range(300):
        n = rng.randrange(0, 4000)
        data = bytes(rng.randrange(256) for _ in range(n))
        if rng.random() < 0.5:
            data = fmu_state.MAGIC + data
        with pytest.raises(StateError):
            fmu_state.decode(data)


# A refused step changes nothing -------------------------------------------------------------------
@pytest.mark.parametrize("method", [1, 2, 3])
def test_refused_step_changes_nothing_and_the_impulse_is_whole(method):
    values = {"solver.method": method, "impact.e": 0.5}
    plain = model_after(0, values)
    probe = model_after(0, values)
    t = 0.0
    impulse_plain = impulse_probe = 0.0
    for k in range(1200):
        if k % 97 == 5:  # refused: bad flow, then bad restitution, then a bad step size
            before = probe.snapshot()
            probe.set("flow.u", float("nan"))
            assert not probe.do_step(t, DT)
            probe.set("flow.u", 0.1)
            probe.set("impact.e", 1.5)
            assert not probe.do_step(t, DT)
            probe.set("impact.e", 0.5)
            assert not probe.do_step(t, -DT)
            pending = before["pending"]
            after = probe.snapshot()
            after["pending"] = pending
            assert after == before
        assert plain.do_step(t, DT) and probe.do_step(t, DT)
        impulse_plain += plain.get("contact.impulse")
        impulse_probe += probe.get("contact.impulse")
        for name in ("structure.x", "ice.z", "contact.impulse", "contact.count"):
            assert plain.get(name) == probe.get(name), (k, name)
        t += DT
    assert impulse_plain == impulse_probe


# Through FMPy -------------------------------------------------------------------------------------
def test_serialized_state_round_trip_is_bit_identical_in_another_instance(fmu_dir,
                                                                         model_description):
    inst = Instance(fmu_dir, model_description, "a")
    other = Instance(fmu_dir, model_description, "b")
    try:
        inst.initialize({"drag.model": 2, "impact.e": 0.5})
        inst.run(3000)
        state = inst.fmu.getFMUstate()
        data = inst.fmu.serializeFMUstate(state)
        assert len(data) <= 16 * 1024
        continuation = columns(inst.run(2000, 3000))
        other.initialize({"ice.M": 400.0})  # another scene: the state brings its own
        restored = other.fmu.deSerializeFMUstate(data)
        other.fmu.setFMUstate(restored)
        again = columns(other.run(2000, 3000))
        other.fmu.freeFMUstate(restored)
        inst.fmu.freeFMUstate(state)
    finally:
        inst.free()
        other.free()
    for name in continuation:
        np.testing.assert_array_equal(again[name], continuation[name], err_msg=name)
    assert not errors(inst) and not errors(other)


#: Two modes at the contact point, plastic impacts: the ice rides on the structure from ~0.53 s.
MODAL = {"structure.model": 3, "structure.modes": 2, "structure.mode2.f": 11.0,
         "structure.mode2.phi": 0.6, "impact.e": 0.0, "flow.u": 0.3, "drag.model": 2,
         "ice.M": 1200.0}
MODAL_OUTPUTS = ("structure.x", "ice.z", "contact.impulse", "contact.count", "contact.active",
                 "structure.mode1.q", "structure.mode1.v", "structure.mode2.q",
                 "structure.mode2.v")


def test_modal_state_mid_ride_round_trips_through_fmi(fmu_dir, model_description):
    """Get, serialize and set an FMU state of the modal structure while the ice rides: the same
    instance set back and another instance (of an SDOF scene) continue identically, loads
    included."""
    inst = Instance(fmu_dir, model_description, "a")
    other = Instance(fmu_dir, model_description, "b")
    loads = {"structure.mode1.load": 400.0, "structure.mode2.load": -250.0}
    try:
        inst.initialize(MODAL)
        rows = inst.run(600)
        assert rows[-1]["contact.active"] and rows[-1]["contact.count"] >= 1  # riding
        inst.set(loads)
        state = inst.fmu.getFMUstate()
        data = inst.fmu.serializeFMUstate(state)
        continuation = columns(inst.run(800, 600))
        inst.fmu.setFMUstate(state)  # set back: the same run again
        again = columns(inst.run(800, 600))
        other.initialize({"ice.M": 400.0})  # another scene: the state brings its own
        restored = other.fmu.deSerializeFMUstate(data)
        other.fmu.setFMUstate(restored)
        elsewhere = columns(other.run(800, 600))
        other.fmu.freeFMUstate(restored)
        inst.fmu.freeFMUstate(state)
    finally:
        inst.free()
        other.free()
    assert np.ptp(continuation["structure.mode2.q"]) > 0.0
    for name in continuation:
        np.testing.assert_array_equal(again[name], continuation[name], err_msg=name)
        np.testing.assert_array_equal(elsewhere[name], continuation[name], err_msg=name)
    # the core under the same loads from the state on
    sim = Simulator(Scene.from_fmi(MODAL))
    for k in range(1400):
        sim.advance((k + 1) * DT - k * DT,
                    loads=(400.0, -250.0) if k >= 600 else None)
    assert continuation["structure.x"][-1] == sim.report.x
    assert continuation["structure.mode2.q"][-1] == sim.report.mode2_q
    assert not errors(inst) and not errors(other)


def test_a_modal_state_of_layout_version_1_is_refused_naming_the_field():
    model = model_after(700, MODAL)
    before = model.snapshot()
    doc = json.loads(fmu_state.encode(before)[len(fmu_state.MAGIC):])
    doc["state"]["simulator"]["version"] = 1
    doc["state"]["simulator"]["solver"]["version"] = 1
    with pytest.raises(StateError, match="state field version = 1 is not allowed: 2"):
        model.restore(fmu_state.decode(fmu_state.MAGIC + json.dumps(doc).encode()))
    assert model.snapshot() == before


def _damaged(data: bytes) -> list[bytes]:
    flipped = bytearray(data)
    flipped[len(flipped) // 2] ^= 0x20
    return [data[:-7], bytes(flipped), b"\x80\x04\x95garbage",
            data.replace(f'"fmu_version":"{VERSION}"'.encode(), b'"fmu_version":"0.1.0"')]


def test_bad_serialized_state_is_refused_and_the_instance_goes_on(fmu_dir, model_description):
    inst = Instance(fmu_dir, model_description)
    try:
        inst.initialize({})
        inst.run(500)
        state = inst.fmu.getFMUstate()
        data = bytes(inst.fmu.serializeFMUstate(state))
        inst.fmu.freeFMUstate(state)
        before = inst.outputs()
        for bad in _damaged(data):
            n = len(inst.messages)
            restored = inst.fmu.deSerializeFMUstate(bad)
            with pytest.raises(FMICallException) as refused:  # fmi2Error
                inst.fmu.setFMUstate(restored)
            assert refused.value.status == FMI_ERROR
            inst.fmu.freeFMUstate(restored)
            refusals = [m for s, _, m in inst.messages[n:] if s == FMI_ERROR]
            assert any("fmi2SetFMUstate refused, the instance is unchanged" in m
                       for m in refusals), inst.messages[n:]
            assert inst.outputs() == before
        rows = columns(inst.run(500, 500))  # goes on as if nothing happened
    finally:
        inst.free()
    reference = Simulator(Scene())
    for k in range(1000):  # the steps Instance.run makes
        reference.advance((k + 1) * DT - k * DT)
    assert rows["structure.x"][-1] == reference.report.x


# Misuse through FMI -------------------------------------------------------------------------------
def test_terminate_twice_reset_after_terminate_and_rerun(fmu_dir, model_description):
    inst = Instance(fmu_dir, model_description)
    try:
        inst.initialize({"impact.e": 0.5})
        first = columns(inst.run(300))
        inst.fmu.terminate()
        try:
            inst.fmu.terminate()  # a second terminate: refused or accepted, never a crash
        except Exception:
            pass
        inst.fmu.reset()
        inst.initialize({"impact.e": 0.5})
        again = columns(inst.run(300))
        inst.fmu.reset()  # reset while initialized and stepping
        inst.initialize({"impact.e": 0.5})
        third = columns(inst.run(300))
    finally:
        inst.free()
    for name in first:
        np.testing.assert_array_equal(again[name], first[name], err_msg=name)
        np.testing.assert_array_equal(third[name], first[name], err_msg=name)


def test_reset_before_initialization_and_doStep_without_initialization(fmu_dir,
                                                                       model_description):
    inst = Instance(fmu_dir, model_description)
    try:
        inst.fmu.reset()  # right after instantiation
        inst.fmu.setupExperiment(startTime=0.0)
        # no enter/exitInitializationMode: the first doStep initializes
        assert inst.step(0.0, DT) == FMI_OK
        assert inst.step(DT, DT) == FMI_OK
        assert inst.step(0.0, DT) == FMI_DISCARD  # the time does not match: refused
        assert "does not match the time of the FMU" in errors(inst)
    finally:
        inst.free()


def test_structure_force_is_the_spring_force():
    """structure.force = k x (the base shear of docs/explanation/design-loads.md), after every
    step."""
    model = model_after(0, {"structure.k": 2.5e6, "impact.e": 0.5})
    for k in range(1500):
        assert model.do_step(k * DT, DT)
        assert model.get("structure.force") == 2.5e6 * model.get("structure.x")


def test_a_non_finite_result_is_refused_and_changes_nothing():
    """A defect that would put NaN in an output: the step is refused (fmi2Discard through the
    adapter), the outputs and the state stay as they were, and the run goes on."""
    model = model_after(200)
    before, outputs = model.snapshot(), {n: model.get(n) for n in ("structure.x", "ice.z")}
    solver = model.sim.solver
    real_advance = solver.advance_to

    def broken(t_end, u):
        real_advance(t_end, u)
        solver.state.x = float("nan")
        return 0.0

    solver.advance_to = broken
    assert not model.do_step(model.time, DT)
    after = model.snapshot()
    assert "non-finite x" in after["simulator"].pop("failed")  # the refusal, recorded
    before["simulator"].pop("failed")
    assert after == before
    assert {n: model.get(n) for n in outputs} == outputs
    solver.advance_to = real_advance
    assert model.do_step(model.time, DT)
    assert np.isfinite(model.get("structure.x"))
