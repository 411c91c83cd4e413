"""The modal structure: the core against closed forms, an ODE reference and an independent
integrator; ModalStructure.fmu against the core (bit for bit), its XML, state and errors."""

from __future__ import annotations

import json
import math
import shutil
import zipfile

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp
from scipy.linalg import expm

from coupling_master import ExactSdof, gauss_seidel
from fmu_host import FMI_ERROR, FMI_OK, Instance, build_module
from iceimpact import ParameterError
from iceimpact.modal import ModalStructure, Mode, contract
from iceimpact.modal.fmu import StateError, decode, encode, structure_from_values

M, C, K = 1600.0, 200.0, 1.0e6  # IceImpact's built-in structure


def one_mode(zeta: float, f: float = 2.0, m: float = 3.0, phi: float = 1.0, **kw):
    return ModalStructure([Mode(f=f, zeta=zeta, m=m, phi=phi)], **kw)


def free_response(w: float, z: float, x0: float, v0: float, t: float) -> float:
    """x(t) of x'' + 2 z w x' + w^2 x = 0: the textbook solution of each regime."""
    if z < 1.0:
        wd = w * math.sqrt(1.0 - z * z)
        return math.exp(-z * w * t) * (x0 * math.cos(wd * t)
                                       + (v0 + z * w * x0) / wd * math.sin(wd * t))
    if z == 1.0:
        return (x0 + (v0 + w * x0) * t) * math.exp(-w * t)
    r1, r2 = -z * w + w * math.sqrt(z * z - 1.0), -z * w - w * math.sqrt(z * z - 1.0)
    b = (v0 - r1 * x0) / (r2 - r1)
    return (x0 - b) * math.exp(r1 * t) + b * math.exp(r2 * t)


# core -------------------------------------------------------------------------------------------
@pytest.mark.parametrize("zeta", [0.0, 0.05, 0.999, 1.0, 1.001, 3.0])
def test_free_decay_every_regime_equals_the_closed_form(zeta):
    s = one_mode(zeta, q0=[0.02], v0=[-0.3])
    w = s.modes[0].omega
    for k in range(1, 401):
        s.advance(2.5e-3, 0.0)
        expected = free_response(w, zeta, 0.02, -0.3, k * 2.5e-3)
        assert s.x == pytest.approx(expected, rel=1e-12, abs=1e-15)


@pytest.mark.parametrize("zeta", [0.0, 0.3, 1.0, 2.5])
def test_step_force_response_and_static_deflection(zeta):
    """From rest, x = F/k + (free response from x0 = -F/k); damped, it settles at F/k."""
    s = one_mode(zeta, phi=0.5)
    mode, force = s.modes[0], 40.0
    x_static = mode.phi ** 2 * force / mode.k   # x = phi q, q driven by phi F
    assert 1.0 / s.stiffness * force == pytest.approx(x_static, rel=1e-15)
    for k in range(1, 201):
        s.advance(0.01, force)
        expected = x_static + mode.phi * free_response(mode.omega, zeta, -x_static / mode.phi,
                                                        0.0, k * 0.01)
        assert s.x == pytest.approx(expected, rel=1e-12, abs=1e-16)
    if zeta > 0.0:
        s.advance(500.0, force)
        assert s.x == pytest.approx(x_static, rel=1e-14)
        assert s.v == pytest.approx(0.0, abs=1e-16)
        assert s.acceleration(force) == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("zeta", [0.0, 1e-3, 0.5, 1 - 1e-9, 1.0, 1 + 1e-9, 2.0, 50.0, 1e4])
@pytest.mark.parametrize("wh", [1e-7, 1e-3, 0.1, 0.4, 0.6, 2.0, 30.0])
def test_step_coefficients_match_the_matrix_exponential(zeta, wh):
    """(s, g) against scipy's expm of the augmented matrix, in each branch of the closed form
    (series, under-/critically/over-damped, both over-damped forms)."""
    mode = Mode(f=4.0, zeta=zeta)
    w = mode.omega
    h = wh / w
    s, g = mode.step_coefficients(h)
    e = expm(h * np.array([[0.0, 1.0, 0.0], [-w * w, -2 * zeta * w, w * w], [0.0, 0.0, 0.0]]))
    # expm is accurate relative to the size of the matrix, not to a decayed entry
    assert s == pytest.approx(e[0, 1], rel=2e-12, abs=1e-13 * h)
    assert g == pytest.approx(e[0, 2], rel=2e-12, abs=1e-13 * min(1.0, wh * wh))


def test_two_modes_superpose():
    a, b = Mode(f=1.5, zeta=0.02, m=10.0, phi=0.8), Mode(f=7.0, zeta=1.3, m=2.0, phi=-0.4)
    both = ModalStructure([a, b], q0=[0.01, -0.002], v0=[0.1, 0.3])
    one_a = ModalStructure([a], q0=[0.01], v0=[0.1])
    one_b = ModalStructure([b], q0=[-0.002], v0=[0.3])
    rng = np.random.default_rng(1)
    for _ in range(300):
        h, force = float(rng.uniform(1e-4, 0.05)), float(rng.normal(0.0, 50.0))
        sa, sb, s2 = one_a.advance(h, force), one_b.advance(h, force), both.advance(h, force)
        assert s2.x == pytest.approx(sa.x + sb.x, rel=1e-13, abs=1e-17)
        assert s2.v == pytest.approx(sa.v + sb.v, rel=1e-13, abs=1e-17)
        assert s2.a == pytest.approx(sa.a + sb.a, rel=1e-12, abs=1e-14)
    assert both.impulse_mass == pytest.approx(1.0 / (0.8 ** 2 / 10.0 + 0.4 ** 2 / 2.0))
    assert a.effective_mass == pytest.approx(10.0 / 0.64)


def test_energy_balance_work_equals_energy_change_plus_damping_loss():
    modes = [Mode(f=1.0, zeta=0.1, m=5.0, phi=1.2), Mode(f=3.0, zeta=1.0, m=1.0, phi=0.7),
             Mode(f=0.5, zeta=2.0, m=2.0, phi=-0.5)]
    s = ModalStructure(modes, q0=[0.01, 0.0, 0.02], v0=[0.0, -0.1, 0.0])
    for h, force in [(0.3, 20.0), (0.05, -7.0), (1.1, 3.0), (0.2, 0.0)]:
        start = s.snapshot()

        def loss_rate(t, start=start, force=force):
            probe = ModalStructure(modes)
            probe.restore(start)
            if t > 0.0:
                probe.advance(t, force)
            return sum(m.c * v * v for m, v in zip(modes, probe.qdot, strict=True))

        e0, x0 = s.energy(), s.x
        s.advance(h, force)
        work = force * (s.x - x0)
        loss = quad(loss_rate, 0.0, h, epsabs=1e-15, epsrel=1e-12, limit=200)[0]
        assert work == pytest.approx(s.energy() - e0 + loss, rel=1e-9, abs=1e-13)


def test_piecewise_constant_force_equals_solve_ivp():
    modes = [Mode(f=3.978873577297384, zeta=0.0025, m=M), Mode(f=11.0, zeta=0.04, m=300.0,
                                                              phi=0.6),
             Mode(f=0.7, zeta=1.0, m=50.0, phi=-0.3), Mode(f=2.0, zeta=4.0, m=20.0, phi=0.2)]
    n = len(modes)
    s = ModalStructure(modes, q0=[1e-3, 0.0, -2e-3, 0.0], v0=[0.0, 0.01, 0.0, 0.0])
    y = np.array(s.q + s.qdot)
    rng = np.random.default_rng(7)
    omega = np.array([m.omega for m in modes])
    zeta = np.array([m.zeta for m in modes])
    drive = np.array([m.phi / m.m for m in modes])
    phi = np.array([m.phi for m in modes])
    for _ in range(40):
        h, force = float(rng.uniform(1e-3, 0.2)), float(rng.normal(0.0, 2000.0))

        def rhs(t, z, force=force):
            q, v = z[:n], z[n:]
            return np.concatenate([v, drive * force - 2 * zeta * omega * v - omega ** 2 * q])

        y = solve_ivp(rhs, (0.0, h), y, method="DOP853", rtol=1e-12, atol=1e-16).y[:, -1]
        state = s.advance(h, force)
        scale = np.abs(y).max()
        assert np.allclose(s.q + s.qdot, y, rtol=1e-9, atol=1e-10 * scale)
        assert state.x == pytest.approx(float(phi @ y[:n]), rel=1e-9, abs=1e-10 * scale)


def test_one_mode_equals_the_independent_integrator_of_the_coupling_tests():
    s = ModalStructure([Mode.from_mck(M, C, K)], q0=[0.003], v0=[-0.02])
    ref = ExactSdof(M, C, K, x0=0.003, v0=-0.02)
    rng = np.random.default_rng(3)
    for _ in range(2000):
        h, force = float(rng.choice([1e-3, 2e-3, 0.0137])), float(rng.normal(0.0, 1e3))
        state = s.advance(h, force)
        x, v, a = ref.step(h, force)
        assert state.x == pytest.approx(x, rel=1e-10, abs=1e-15)
        assert state.v == pytest.approx(v, rel=1e-10, abs=1e-14)
        assert state.a == pytest.approx(a, rel=1e-9, abs=1e-11)
    assert s.energy() == pytest.approx(ref.energy(), rel=1e-9)


def test_gauss_seidel_master_delivers_the_ice_impulse():
    class Kick:
        def __init__(self):
            self.seen = []

        def step(self, t, h, x_in, v_in, a_in):
            self.seen.append((t, h, x_in, v_in, a_in))
            return 2.0 if t == 0.0 else 0.0

    ice = Kick()
    run = gauss_seidel(ice, ExactSdof(M, C, K), t_end=0.5, h=1e-3, second_order=True)
    assert len(run.t) == 501 and run.t[-1] == 0.5
    assert run.force[0] == pytest.approx(2000.0) and not run.force[1:].any()
    assert ice.seen[1][4] == pytest.approx((2000.0 - K * run.x[1] - C * run.v[1]) / M)
    # a push of 2 N.s over the first step: an impulse at its middle, up to O((omega h)^2)
    w, z = math.sqrt(K / M), C / (2 * math.sqrt(K * M))
    assert run.x[-1] == pytest.approx(free_response(w, z, 0.0, 2.0 / M, 0.5 - 0.5e-3),
                                      rel=(w * 1e-3) ** 2 / 10)


def test_validation_names_variable_value_and_range():
    with pytest.raises(ParameterError, match=r"mode\.zeta = -0\.1 is not allowed: >= 0"):
        Mode(f=1.0, zeta=-0.1)
    with pytest.raises(ParameterError, match=r"mode3\.f = 0\.0 is not allowed: > 0 Hz"):
        Mode(f=0.0, name="mode3")
    with pytest.raises(ParameterError, match=r"mode\.m = nan is not allowed: a finite number"):
        Mode(f=1.0, m=float("nan"))
    with pytest.raises(ParameterError, match=r"h = 0\.0 is not allowed"):
        one_mode(0.1).advance(0.0, 1.0)
    with pytest.raises(ParameterError, match=r"force = inf"):
        one_mode(0.1).advance(1e-3, math.inf)
    values = {p.name: p.start for p in contract.PARAMETERS}
    with pytest.raises(ParameterError, match=r"modes = 6 is not allowed: 1 <= modes <= 5"):
        structure_from_values({**values, "modes": 6})
    values["mode2.m"] = -1.0  # ignored while only one mode is used
    assert structure_from_values(values).n == 1
    with pytest.raises(ParameterError, match=r"mode2\.m = -1\.0 is not allowed: > 0 kg"):
        structure_from_values({**values, "modes": 2})


def test_contract_defaults_are_iceimpacts_structure():
    mode = Mode.from_mck(M, C, K)
    s = structure_from_values({p.name: p.start for p in contract.PARAMETERS})
    assert s.modes[0].f == mode.f and s.modes[0].zeta == mode.zeta and s.modes[0].m == M
    assert s.impulse_mass == M and s.stiffness == pytest.approx(K, rel=1e-15)


# the FMU ------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def modal_fmu(tmp_path_factory):
    return build_module().build_modal(tmp_path_factory.mktemp("modal_dist"))


@pytest.fixture(scope="module")
def modal_dir(modal_fmu, tmp_path_factory):
    folder = tmp_path_factory.mktemp("modal_fmu")
    shutil.unpack_archive(modal_fmu, folder, "zip")
    return str(folder)


def call_status(function, *args) -> int:
    """The FMI status of an FMPy call (FMPy raises on fmi2Discard and fmi2Error)."""
    from fmpy.fmi1 import FMICallException

    try:
        function(*args)
    except FMICallException as exc:
        return exc.status
    return FMI_OK


class Slave:
    """ModalStructure.fmu stepped by hand through FMPy, keeping every log message.

    Built on tests/fmu_host.py's Instance for its process-wide logger: a logger per Slave, given
    to FMPy's one logger proxy, was left dangling once the Slave was collected, and a later
    simulate_fmu in the same process crashed or lost its messages.
    """

    def __init__(self, fmu_dir: str):
        from fmpy import read_model_description

        md = read_model_description(fmu_dir)
        self._instance = Instance(fmu_dir, md, "structure")
        self.fmu = self._instance.fmu
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.time = 0.0

    @property
    def messages(self) -> list[tuple[int, str]]:
        return [(status, message) for status, _, message in self._instance.messages]

    def initialize(self, values: dict) -> None:
        self.fmu.setupExperiment(startTime=0.0)
        for name, value in values.items():
            setter = self.fmu.setInteger if name == "modes" else self.fmu.setReal
            setter([self.vr[name]], [value])
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()

    def step(self, h: float, force: float) -> int:
        from fmpy.fmi1 import FMICallException

        self.fmu.setReal([self.vr["force"]], [force])
        try:
            self.fmu.doStep(currentCommunicationPoint=self.time, communicationStepSize=h)
        except FMICallException as exc:
            return exc.status
        self.time += h
        return FMI_OK

    def outputs(self) -> tuple[float, float, float]:
        return tuple(self.fmu.getReal([self.vr["x"], self.vr["v"], self.vr["a"]]))


TWO_MODES = {"modes": 2, "mode1.f": 3.1, "mode1.zeta": 0.01, "mode1.m": 900.0, "mode1.phi": 1.1,
             "mode1.q0": 1e-3, "mode2.f": 17.0, "mode2.zeta": 1.0, "mode2.m": 120.0,
             "mode2.phi": -0.45, "mode2.v0": 0.02}


def core_of(values: dict) -> ModalStructure:
    return structure_from_values({**{p.name: p.start for p in contract.PARAMETERS}, **values})


def test_fmu_validates_and_declares_the_contract(modal_fmu):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(modal_fmu)) == []
    md = read_model_description(str(modal_fmu))
    assert md.coSimulation.modelIdentifier == "ModalStructure"
    assert md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate
    by_name = {v.name: v for v in md.modelVariables}
    assert list(by_name) == [v.name for v in contract.VARIABLES]
    for spec in contract.VARIABLES:
        var = by_name[spec.name]
        assert var.causality == spec.causality and var.description == spec.description
        assert (var.unit or "") == spec.unit
        if spec.start is not None:  # the contract's double, to the last bit
            assert type(spec.start)(var.start) == spec.start, spec.name
    assert by_name["mode1.f"].unit == "Hz" and by_name["a"].unit == "m/s2"
    with zipfile.ZipFile(modal_fmu) as z:
        names = set(z.namelist())
    assert {"binaries/linux64/ModalStructure.so", "binaries/linux64/pythonfmu/ModalStructure.so",
            "resources/iceimpact_fmu/ModalStructure.py",
            "resources/iceimpact/modal/structure.py"} <= names


def test_fmu_equals_the_core_bit_for_bit(modal_dir):
    slave = Slave(modal_dir)
    slave.initialize(TWO_MODES)
    core = core_of(TWO_MODES)
    assert slave.outputs() == (core.x, core.v, core.acceleration(0.0))
    rng = np.random.default_rng(11)
    for _ in range(500):
        h, force = float(rng.choice([1e-3, 1e-3, 2.5e-4, 0.01])), float(rng.normal(0, 500.0))
        assert slave.step(h, force) == FMI_OK, slave.messages
        assert slave.outputs() == tuple(core.advance(h, force))
    slave.fmu.freeInstance()


def test_fmu_state_round_trip_is_bit_identical(modal_dir):
    slave = Slave(modal_dir)
    slave.initialize(TWO_MODES)
    forces = np.random.default_rng(5).normal(0.0, 300.0, 200)
    for force in forces[:100]:
        slave.step(1e-3, float(force))
    blob = slave.fmu.serializeFMUstate(slave.fmu.getFMUstate())
    assert blob.startswith(b"ModalStructure FMU state\n")
    json.loads(blob[len(b"ModalStructure FMU state\n"):])  # plain JSON, no pickle
    time = slave.time
    first = []
    for force in forces[100:]:
        slave.step(1e-3, float(force))
        first.append(slave.outputs())
    other = Slave(modal_dir)  # a fresh instance, never initialized
    other.fmu.setFMUstate(other.fmu.deSerializeFMUstate(blob))
    other.time = time
    assert not [m for s, m in other.messages if s >= FMI_ERROR]
    second = []
    for force in forces[100:]:
        assert other.step(1e-3, float(force)) == FMI_OK, other.messages
        second.append(other.outputs())
    assert first == second
    # a damaged blob is refused (fmi2Error) with its reason and changes nothing
    before = other.outputs()
    damaged = other.fmu.deSerializeFMUstate(blob.replace(b'"q"', b'"p"'))
    assert call_status(other.fmu.setFMUstate, damaged) == FMI_ERROR
    assert other.outputs() == before
    assert any("refused" in m and "field structure" in m for s, m in other.messages
               if s >= FMI_ERROR), other.messages
    for inst in (slave, other):
        inst.fmu.freeInstance()


def test_state_record_refusals():
    core = core_of({})
    record = {"values": {p.name: p.start for p in contract.PARAMETERS}, "force": 1.0,
              "step_force": 1.0, "start_time": 0.0, "time": 0.5, "error": None,
              "structure": core.snapshot()}
    assert decode(encode(record)) == record
    for bad, match in [
            (encode({**record, "time": math.nan}), "time = nan"),
            (encode({**record, "structure": {"q": ["0"], "qdot": [0.0]}}), r"structure.q\[0\]"),
            (encode({**record, "values": {"modes": 1}}), "every parameter"),
            (b"\x80\x04pickle", "not a state of ModalStructure.fmu"),
            (encode(record)[:-5], "damaged")]:
        with pytest.raises(StateError, match=match):
            decode(bad)


def test_bad_parameter_is_logged_and_every_step_refused(modal_dir):
    slave = Slave(modal_dir)
    slave.initialize({"modes": 2, "mode2.m": -1.0})
    message = "mode2.m = -1.0 is not allowed: > 0 kg"
    assert any(message in m for s, m in slave.messages if s == FMI_ERROR), slave.messages
    assert slave.step(1e-3, 0.0) == FMI_ERROR
    assert any(m.startswith("doStep refused") and message in m for _, m in slave.messages)
    slave.fmu.freeInstance()
    ok = Slave(modal_dir)
    ok.initialize({})
    assert ok.step(1e-3, math.nan) != FMI_OK  # refused, the state is unchanged
    assert ok.outputs() == (0.0, 0.0, 0.0)
    assert ok.step(1e-3, 100.0) == FMI_OK
    # fixed after initialization: refused with fmi2Error, as IceImpact.fmu refuses it
    assert call_status(ok.fmu.setReal, [ok.vr["mode1.m"]], [5.0]) == FMI_ERROR
    assert any(s == FMI_ERROR and "mode1.m is a fixed parameter: setting it to 5.0" in m
               and "1600.0, is kept" in m for s, m in ok.messages), ok.messages
    assert ok.fmu.getReal([ok.vr["mode1.m"]]) == [M]
    assert ok.step(1e-3, 100.0) == FMI_OK  # and the instance goes on
    ok.fmu.freeInstance()


def test_native_host_with_an_empty_environment_equals_the_core(modal_dir, tmp_path):
    """The C host of tests/c_host under env -i: the loader and boot.py serve this FMU too."""
    import subprocess
    from pathlib import Path

    compiler = shutil.which("cc") or shutil.which("gcc")
    if compiler is None:
        pytest.skip("no C compiler")
    host = tmp_path / "host"
    source = Path(__file__).parents[1] / "c_host" / "host.c"
    subprocess.run([compiler, "-O2", "-o", str(host), str(source), "-ldl"], check=True)
    done = subprocess.run([str(host), modal_dir, "-n", "50", "-h", "0.001", "-s", "modes=2",
                           "-s", "mode2.phi=0.5", "-s", "mode2.f=9", "-s", "mode1.q0=0.01",
                           "-o", "x", "-o", "v"], env={}, capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
    rows = [[float(x) for x in line.split(",")] for line in done.stdout.strip().splitlines()[1:]]
    core = core_of({"modes": 2, "mode2.phi": 0.5, "mode2.f": 9.0, "mode1.q0": 0.01})
    expected = [[0.0, core.x, core.v]]
    for k in range(1, 51):  # the host's communication points are k h
        state = core.advance(k * 1e-3 - (k - 1) * 1e-3, 0.0)
        expected.append([k * 1e-3, state.x, state.v])
    assert rows == expected  # printed with %.17g: the same doubles


def test_docs_list_the_contract():
    """The documentation's page of FMU variables is made from this contract at every build."""
    import importlib.util
    from pathlib import Path

    hooks_file = Path(__file__).parents[2] / "scripts" / "docs_hooks.py"
    spec = importlib.util.spec_from_file_location("docs_hooks", hooks_file)
    hooks = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(hooks)
    assert contract.markdown_table() in hooks.fmu_variables_page()


def test_the_python_api_takes_numpy_numbers_and_refuses_huge_ones():
    """advance(np.float32(0.01), np.int64(5)) was refused, advance(10**400, 0) and
    Mode(f=10**400) raised a bare OverflowError."""
    a = ModalStructure([Mode(f=np.float32(2.0), zeta=np.int64(0), m=1.0)])
    b = ModalStructure([Mode(f=2.0, zeta=0.0, m=1.0)])
    assert a.advance(np.float32(0.01), np.int64(5)) == b.advance(float(np.float32(0.01)), 5.0)
    for call, value, name in ((lambda v: a.advance(v, 0.0), 10**400, "h"),
                              (lambda v: a.advance(v, 0.0), np.bool_(True), "h"),
                              (lambda v: a.advance(0.01, v), -(10**400), "force"),
                              (lambda v: Mode(f=v, zeta=0.0, m=1.0), 10**400, "mode.f")):
        with pytest.raises(ParameterError) as err:
            call(value)
        assert err.value.name == name and err.value.value is value
