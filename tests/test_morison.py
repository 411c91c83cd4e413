"""Morison loads on the structure (docs/explanation/morison.md): added mass rho Ca V and drag
``F_s = rho Cd A |u - v| (u - v) / 2`` (or its linearisation about drag.v_lin), each off unless a
scene asks for it.

Every claim is checked against something that shares no code with the solvers: closed forms
(the period 2 pi sqrt((m + rho Ca V) / k), the static offset of the drag), the work integrals of an
energy balance computed from dense samples, and a direct scipy integration (ode_reference).
With the four parameters at 0 no Morison code runs, so the numbers are the model's without them.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import morison_off_cases
from iceimpact import ParameterError, Scene, Simulator
from iceimpact.simulator import run
from iceimpact.solvers import contact_rules
from iceimpact.solvers import fixed_step as fixed_step_solver
from iceimpact.solvers import ode as ode_solver
from iceimpact.solvers.exact import context as exact_context
from iceimpact.solvers.exact import solver as event_solver
from ode_reference import simulate as ode_simulate

RHO = Scene().fluid_rho
#: A 1 m diameter leg with 1 m of draft (docs/explanation/morison.md): Ca = 1, V = pi/4 m^3, Cd = 1,
#: A = 1 m^2.
PILE = {"structure_Ca": 1.0, "structure_V": math.pi / 4, "structure_Cd": 1.0, "structure_A": 1.0}
#: The structure alone: the ice far upstream, at rest, undragged.
ALONE = {"ice_z0": -1.0e3, "ice_v0": 0.0, "ice_Cd": 0.0}


# -- all four at 0: today's numbers ---------------------------------------------------------------

OFF = [
    {},
    {"structure_Ca": 0.0, "structure_V": 0.0, "structure_Cd": 0.0, "structure_A": 0.0},
    {"structure_Ca": 0.0, "structure_V": 5.0, "structure_Cd": 0.0, "structure_A": 3.0},
    {"structure_Ca": 1.5, "structure_V": 0.0, "structure_Cd": 1.2, "structure_A": 0.0},
]
OFF_IDS = ["defaults", "all zero", "zero coefficients", "zero volume and area"]


def _forbid_morison_code(monkeypatch) -> None:
    """Every entry point of the Morison terms raises if called."""
    def forbidden(*args, **kwargs):
        raise AssertionError("Morison code ran with the terms off")
    for module, names in (
            (event_solver, ("DraggedStructure", "DraggedFlight")),
            (exact_context, ("morison_oscillator",)),
            (fixed_step_solver, ("morison_oscillator",)),
            (contact_rules, ("TogetherWithStructureDrag",)),
            (ode_solver, ("_DraggedFlight",))):
        for name in names:
            monkeypatch.setattr(module, name, forbidden)


@pytest.fixture(scope="module")
def digests_without_the_parameters():
    return morison_off_cases.compute()


@pytest.mark.parametrize("extra", OFF, ids=OFF_IDS)
def test_morison_off_runs_no_morison_code(extra, monkeypatch, digests_without_the_parameters):
    """With both products (Ca V, Cd A) at 0 no Morison code runs: nine runs (three methods, both
    drag laws, sticking, a flow reversal; tests/morison_off_cases.py) go through none of its
    entry points and report the same bits, whichever factors are set. The same digests against
    the tree before the Morison terms existed: ``benchmarks/morison_cost.py`` (its "same bits"
    column), which runs that commit side by side."""
    _forbid_morison_code(monkeypatch)
    for method in (1, 2, 3):
        for drag in (1, 2):
            solver = Simulator(Scene(solver_method=method, drag_model=drag, **extra)).solver
            assert solver.structure_drag is None
            assert solver.m == Scene().structure_m
    assert morison_off_cases.compute(extra) == digests_without_the_parameters


# -- added mass: the period ------------------------------------------------------------------------

def _zero_crossings(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Times of the upward zero crossings of x, by linear interpolation (x'' = 0 there, so the
    error is third order in the sample step)."""
    i = np.nonzero((x[:-1] < 0.0) & (x[1:] >= 0.0))[0]
    return t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i])


@pytest.mark.parametrize(("method", "drag"), [(1, 1), (1, 2), (2, 1), (3, 1), (3, 2)])
def test_free_vibration_period_with_added_mass(method, drag):
    Ca, V = 1.0, 2.0  # m_a = 1998 kg, more than the structure's own 1600 kg
    scene = Scene(structure_c=0.0, structure_x0=1e-3, structure_Ca=Ca, structure_V=V,
                  flow_u=0.0, drag_model=drag, solver_method=method, solver_rtol=1e-12,
                  solver_dt=1e-5, **{**ALONE, "ice_z0": -1.0})
    expected = 2.0 * math.pi * math.sqrt((scene.structure_m + RHO * Ca * V) / scene.structure_k)
    res = run(scene, 2.0, dt=1e-4)
    crossings = _zero_crossings(res.t, res.x)
    assert len(crossings) >= 5
    period = (crossings[-1] - crossings[0]) / (len(crossings) - 1)
    assert period == pytest.approx(expected, rel=1e-6)
    assert period / (2.0 * math.pi / Scene().omega_n) > 1.4  # far from the dry period
    assert scene.omega_n == pytest.approx(2.0 * math.pi / expected, rel=1e-15)


# -- drag: the static offset -----------------------------------------------------------------------

@pytest.mark.parametrize("method", [1, 2, 3])
def test_static_offset_under_linearised_drag(method):
    """k x = b_s u with b_s = rho Cd A v_lin / 2, once the transient has died out."""
    Cd, A, u = 1.2, 3.0, 0.4
    scene = Scene(structure_c=4.0e4, structure_Cd=Cd, structure_A=A, flow_u=u, drag_model=1,
                  solver_method=method, solver_rtol=1e-12, **ALONE)
    expected = 0.5 * RHO * Cd * A * scene.drag_v_lin * u / scene.structure_k
    res = run(scene, 3.0, dt=0.1)
    assert res.x[-1] == pytest.approx(expected, rel=1e-9)
    assert len(res.impacts) == 0


@pytest.mark.parametrize("method", [1, 3])
def test_static_offset_under_quadratic_drag(method):
    """k x = B_s |u| u with B_s = rho Cd A / 2 (the structure at rest in the flow)."""
    Cd, A, u = 1.2, 3.0, -0.4
    scene = Scene(structure_c=4.0e4, structure_Cd=Cd, structure_A=A, flow_u=u, drag_model=2,
                  solver_method=method, solver_rtol=1e-12, **ALONE)
    expected = 0.5 * RHO * Cd * A * abs(u) * u / scene.structure_k
    res = run(scene, 3.0, dt=0.1)
    assert res.x[-1] == pytest.approx(expected, rel=1e-8)


@pytest.mark.parametrize(("method", "drag"), [(1, 1), (1, 2), (3, 1), (3, 2), (2, 1)])
def test_sticking_equilibrium_and_contact_force(method, drag):
    """Bodies at rest together in the flow: k x = F_ice + F_s (both drags push), while the contact
    force is the ice's drag alone (the structure's own drag acts on it directly)."""
    u = 0.3
    scene = Scene(**PILE, impact_e=0.0, structure_c=4.0e4, flow_u=u, drag_model=drag,
                  solver_method=method, solver_detection=2, solver_rtol=1e-10)
    B, B_s = 0.5 * RHO * scene.ice_Cd * scene.ice_A, 0.5 * RHO * scene.structure_Cd * 1.0
    if drag == 2:
        f_ice, f_s = B * u * u, B_s * u * u
    else:
        f_ice, f_s = B * scene.drag_v_lin * u, B_s * scene.drag_v_lin * u
    sim = Simulator(scene)
    sim.advance_to(20.0)
    report = sim.advance(0.5)
    assert report.sticking
    assert report.x == pytest.approx((f_ice + f_s) / scene.structure_k, rel=1e-6)
    assert report.force == pytest.approx(f_ice, rel=1e-6)


# -- energy balance --------------------------------------------------------------------------------

def _trapezoid(y: np.ndarray, t: np.ndarray) -> float:
    return float(np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(t)))


@pytest.mark.parametrize(("method", "drag"), [(1, 1), (1, 2), (3, 2)])
def test_energy_balance_with_structure_drag(method, drag):
    """E(T) - E(0) = drag work on the ice + drag work on the structure - damping - impact losses,
    E = (m + m_a) v^2 / 2 + k x^2 / 2 + M w^2 / 2. The work integrals come from dense samples
    (trapezoid, 0.1 ms), the impact losses from the recorded velocities."""
    scene = Scene(**PILE, impact_e=0.5, flow_u=0.3, drag_model=drag, solver_method=method,
                  solver_rtol=1e-11)
    t_end = 4.0
    res = run(scene, t_end, dt=1e-4)
    m_eff = scene.structure_m + RHO * scene.structure_Ca * scene.structure_V
    M, k, c, u = scene.ice_M, scene.structure_k, scene.structure_c, scene.flow_u
    B = 0.5 * RHO * scene.ice_Cd * scene.ice_A
    B_s = 0.5 * RHO * scene.structure_Cd * scene.structure_A
    t, x, v, w = res.t, res.x, res.v, res.w
    if drag == 2:
        f_ice, f_s = -B * np.abs(w - u) * (w - u), B_s * np.abs(u - v) * (u - v)
    else:
        f_ice, f_s = -B * scene.drag_v_lin * (w - u), B_s * scene.drag_v_lin * (u - v)
    energy = 0.5 * m_eff * v * v + 0.5 * k * x * x + 0.5 * M * w * w
    work_ice = _trapezoid(f_ice * w, t)
    work_structure = _trapezoid(f_s * v, t)
    damping = _trapezoid(c * v * v, t)
    imp = res.impacts
    losses = float(np.sum(0.5 * m_eff * (imp["v_minus"] ** 2 - imp["v_plus"] ** 2)
                          + 0.5 * M * (imp["w_minus"] ** 2 - imp["w_plus"] ** 2)))
    assert len(imp) >= 5 and losses > 0.0
    assert abs(work_structure) > 1e-3 * abs(work_ice)  # the structure's drag term matters
    balance = energy[-1] - energy[0] - (work_ice + work_structure - damping - losses)
    scale = abs(work_ice) + abs(work_structure) + damping + losses
    assert abs(balance) < 1e-4 * scale, (balance, scale)  # 2e-5 measured; 5e-3 without F_s


# -- the impacts against an independent integration ------------------------------------------------

@pytest.mark.parametrize(("method", "drag", "tolerance"), [
    (1, 1, 1e-9), (1, 2, 1e-9), (3, 1, 1e-6), (3, 2, 1e-6), (2, 1, 2e-4)])
def test_impacts_agree_with_scipy(method, drag, tolerance):
    """Impact times and velocities of the first impacts with both Morison terms on match a direct
    DOP853 integration with terminal gap events (tests/ode_reference.py, rtol 1e-12)."""
    scene = Scene(**PILE, flow_u=0.3, ice_v0=0.3, ice_M=400.0, ice_A=20.0, impact_e=0.8,
                  drag_model=drag, solver_method=method, solver_detection=2, solver_dt=1e-6,
                  solver_rtol=1e-10)
    ref = ode_simulate(scene, 1.0, max_impacts=8, atol=1e-16)
    sim = Simulator(scene)
    sim.advance_to(1.0)
    ours = sim.impacts[:8]
    n = min(len(ours), len(ref["t"]))
    assert n >= 4
    assert np.max(np.abs(np.array([i.t for i in ours[:n]]) - ref["t"][:n])) < tolerance
    speed = max(abs(scene.flow_u), abs(scene.ice_v0))
    assert np.max(np.abs(np.array([i.v_plus for i in ours[:n]]) - ref["v_plus"][:n])) < (
        1e3 * tolerance * speed)


def test_dragged_flight_does_not_depend_on_the_communication_step():
    scene = Scene(**PILE, drag_model=2, impact_e=0.5, flow_u=0.3)
    times = []
    for h in (1e-3, 0.25):
        sim = Simulator(scene)
        for _ in range(round(3.0 / h)):
            sim.advance(h)
        times.append([i.t for i in sim.impacts])
    assert len(times[0]) >= 5 and times[0] == times[1]


def test_dragged_flight_state_round_trip():
    """A run saved in the middle of an integrated flight and restored (through JSON) continues
    with the same bits as the run that went on."""
    scene = Scene(**PILE, drag_model=2, impact_e=0.8, flow_u=0.3)
    sim = Simulator(scene)
    for _ in range(137):
        sim.advance(1e-2)
    assert not sim.solver.sticking and type(sim.solver.seg).__name__ == "DraggedFlight"
    saved = json.loads(json.dumps(sim.save()))
    first = [sim.advance(1e-2) for _ in range(150)]
    sim.restore(saved)
    again = [sim.advance(1e-2) for _ in range(150)]
    assert first == again
    fresh = Simulator(scene)
    fresh.restore(saved)
    assert [fresh.advance(1e-2) for _ in range(150)] == first


@pytest.mark.parametrize("drag", [1, 2])
def test_restored_states_continue_with_the_same_bits_everywhere(drag):
    """Saved every 70 ms over a run with impacts, chatter and sticking (any phase, right after
    events), each state restored into a fresh simulator continues as the run did."""
    scene = Scene(**PILE, drag_model=drag, impact_e=0.5, flow_u=0.3, ice_v0=0.3, ice_M=400.0,
                  ice_A=20.0)
    sim = Simulator(scene)
    phases = set()
    for k in range(40):
        saved = sim.save()
        ahead = [sim.advance(7e-3) for _ in range(10)]
        phases.update(r.sticking for r in ahead)
        other = Simulator(scene)
        other.restore(json.loads(json.dumps(saved)))
        assert [other.advance(7e-3) for _ in range(10)] == ahead, k
    assert sim.solver.impact_count >= 5 and phases == {False, True}


# -- what is refused -------------------------------------------------------------------------------

@pytest.mark.parametrize(("changes", "name", "says"), [
    ({"structure_model": 2, "structure_Ca": 1.0, "structure_V": 1.0}, "structure.Ca",
     "external structure"),
    ({"structure_model": 2, "structure_Cd": 1.0, "structure_A": 1.0}, "structure.Cd",
     "external structure"),
    ({"solver_method": 2, "drag_model": 2, "structure_Cd": 1.0, "structure_A": 1.0},
     "structure.Cd", "has none"),
    ({"structure_Ca": -1.0}, "structure.Ca", ">= 0"),
    ({"structure_A": math.inf}, "structure.A", "finite"),
    ({"structure_Ca": 1e300, "structure_V": 1e300}, "fluid.rho * structure.Ca * structure.V",
     "finite"),
    ({"solver_method": 3, "drag_model": 2, "structure_Cd": 1.0, "structure_A": 1e8},
     "max(|flow.u|, |flow.u - structure.v0|)", "1e+06 1/s"),
    ({"solver_method": 1, "drag_model": 2, "structure_Cd": 1.0, "structure_A": 1e8},
     "max(|flow.u|, |flow.u - structure.v0|)", "1e+06 1/s"),
    ({"solver_method": 3, "drag_model": 1, "structure_Cd": 1.0, "structure_A": 1e9},
     "B_s * drag.v_lin / (structure.m + m_a)", "1e+06 1/s"),
])
def test_unsupported_or_meaningless_morison_scenes_are_refused(changes, name, says):
    with pytest.raises(ParameterError) as info:
        Scene(**changes)
    assert info.value.name == name and says in str(info.value)


def test_a_flow_whose_structure_drag_overflows_is_refused():
    # b_s = 5e156 kg/s: b_s u overflows while the ice's drag and kinetic energy do not
    scene = Scene(**{**PILE, "structure_A": 1e155}, drag_model=1, solver_method=2)
    with pytest.raises(ParameterError) as info:
        Simulator(scene).advance(1e-3, 1e152)
    assert info.value.name == "flow.u" and "drag force on the structure" in str(info.value)


def test_a_flow_too_fast_for_the_structure_drag_is_refused_during_the_run():
    sim = Simulator(Scene(**{**PILE, "structure_A": 100.0}, drag_model=2, solver_method=1))
    with pytest.raises(ParameterError) as info:
        sim.advance(1e-3, 1e5)  # within the ice's limit (1.6e6 m/s), not the structure's
    assert info.value.name == "flow.u" and "Morison drag rate" in str(info.value)
    assert sim.t == 0.0


def test_quadratic_sticking_with_structure_drag_follows_scipy():
    """Bodies together under quadratic drag on both (method 1's Taylor steps with B + B_s):
    ``(m + m_a + M) x'' + c x' + k x = (B + B_s) |u - x'| (u - x')``, against solve_ivp at rtol
    1e-12 written out here; the contact force stays the ice's drag minus its inertia (>= 0)."""
    from scipy.integrate import solve_ivp
    u = 0.8
    scene = Scene(**PILE, impact_e=0.0, flow_u=u, drag_model=2, structure_x0=0.0,
                  structure_v0=0.0, ice_z0=0.0, ice_v0=0.0)
    total = scene.structure_m + RHO * PILE["structure_Ca"] * PILE["structure_V"] + scene.ice_M
    B = 0.5 * RHO * scene.ice_Cd * scene.ice_A
    B_s = 0.5 * RHO * PILE["structure_Cd"] * PILE["structure_A"]
    c, k = scene.structure_c, scene.structure_k

    def rhs(t, y):
        r = u - y[1]
        return [y[1], ((B + B_s) * abs(r) * r - c * y[1] - k * y[0]) / total]

    times = np.linspace(0.1, 2.0, 20)
    ref = solve_ivp(rhs, (0.0, 2.0), [0.0, 0.0], method="DOP853", rtol=1e-12, atol=1e-15,
                    t_eval=times)
    sim = Simulator(scene)
    scale = np.max(np.abs(ref.y[0]))
    for i, t in enumerate(times):
        report = sim.advance_to(float(t))
        assert report.sticking
        assert report.x == pytest.approx(ref.y[0, i], abs=1e-9 * scale)
        assert report.z == report.x
        assert report.impulse >= 0.0
