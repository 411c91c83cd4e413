"""The exact event-driven solver: conservation laws, an energy balance, an independent ODE
integration, grazing touches, sticking, bounded work."""

import math

import numpy as np
import pytest

from iceimpact import Scene, Simulator, run
from iceimpact.physics.contact import impact_energy_loss
from ode_reference import simulate as ode_simulate

FIG2 = Scene()
QUAD = Scene(drag_model=2)
HEAVY_LIGHT = Scene(ice_M=400.0, impact_e=0.8)
SCENES = {"fig2": FIG2, "quadratic": QUAD, "M400_e0.8": HEAVY_LIGHT,
          "e0.5": Scene(impact_e=0.5), "quad_e0.5": Scene(impact_e=0.5, drag_model=2),
          "overdamped": Scene(structure_c=2.0 * 5 * math.sqrt(1e6 * 1600))}


@pytest.fixture(scope="module")
def runs():
    return {name: run(scene, 40.0) for name, scene in SCENES.items()}


@pytest.mark.parametrize("name", list(SCENES))
def test_momentum_and_restitution_at_every_impact(runs, name):
    scene, imp = SCENES[name], runs[name].impacts
    assert len(imp) > 0
    m, M = scene.structure_m, scene.ice_M
    before = m * imp["v_minus"] + M * imp["w_minus"]
    after = m * imp["v_plus"] + M * imp["w_plus"]
    assert np.all(np.abs(after - before) <= 1e-12 * np.abs(before) + 1e-18)
    closing = imp["w_minus"] - imp["v_minus"]
    assert np.all(closing >= 0.0)
    opening = imp["v_plus"] - imp["w_plus"]
    assert np.allclose(opening, imp["restitution"] * closing, rtol=1e-12, atol=1e-18)
    # the applied e is the scene's, except a plastic impact (e = 0) closing a bounce sequence
    assert np.all((imp["restitution"] == scene.impact_e) | (imp["restitution"] == 0.0))
    assert np.allclose(imp["impulse"], m * (imp["v_plus"] - imp["v_minus"]), rtol=1e-14)


@pytest.mark.parametrize("name", ["fig2", "quadratic"])
def test_kinetic_energy_conserved_at_elastic_impacts(runs, name):
    scene, imp = SCENES[name], runs[name].impacts
    m, M = scene.structure_m, scene.ice_M
    elastic = imp[imp["restitution"] == 1.0]
    assert len(elastic) >= 8
    ke_before = 0.5 * m * elastic["v_minus"] ** 2 + 0.5 * M * elastic["w_minus"] ** 2
    ke_after = 0.5 * m * elastic["v_plus"] ** 2 + 0.5 * M * elastic["w_plus"] ** 2
    assert np.allclose(ke_after, ke_before, rtol=1e-12, atol=0)


def _gauss_times(boundaries, t_end, h=0.01, order=5):
    """Gauss-Legendre nodes and weights on [0, t_end], never straddling an impact time."""
    nodes, weights = np.polynomial.legendre.leggauss(order)
    edges = np.unique(np.concatenate([[0.0], boundaries[boundaries < t_end], [t_end]]))
    ts, ws = [], []
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        n = max(1, int(math.ceil((b - a) / h)))
        sub = np.linspace(a, b, n + 1)
        lo, hi = sub[:-1, None], sub[1:, None]
        ts.append(((hi - lo) / 2 * nodes + (hi + lo) / 2).ravel())
        ws.append(((hi - lo) / 2 * weights).ravel())
    t, w = np.concatenate(ts), np.concatenate(ws)
    keep = np.concatenate([[True], np.diff(t) > 0])
    return t[keep], w[keep]


def _drag_force(scene, w, u):
    B = 0.5 * scene.fluid_rho * scene.ice_Cd * scene.ice_A
    r = w - u
    return -B * np.abs(r) * r if scene.drag_model == 2 else -B * scene.drag_v_lin * r


@pytest.mark.parametrize("name", ["fig2", "quadratic", "M400_e0.8", "e0.5", "quad_e0.5",
                                  "overdamped"])
def test_energy_balance_over_a_run(name):
    """E(end) - E(0) = drag work - structural damping loss - impact losses (quadrature)."""
    scene = SCENES[name]
    t_end = 30.0
    first = run(scene, t_end)
    # quadrature panels short against the fastest structural time scale
    fastest = scene.structure_c / scene.structure_m + scene.omega_n
    t, wts = _gauss_times(first.impacts["t"], t_end, h=min(0.01, 0.5 / fastest))
    res = run(scene, t_end, sample_times=np.append(t, t_end))
    assert np.array_equal(res.impacts["t"], first.impacts["t"])  # sampling changes nothing
    v, w = res.v[1:-1], res.w[1:-1]
    drag_work = np.sum(wts * _drag_force(scene, w, scene.flow_u) * w)
    damping_loss = np.sum(wts * scene.structure_c * v * v)
    imp = res.impacts
    impact_loss = sum(impact_energy_loss(i["v_minus"], i["w_minus"], scene.structure_m,
                                         scene.ice_M, i["restitution"]) for i in imp)

    def energy(k):
        return (0.5 * scene.structure_m * res.v[k] ** 2 + 0.5 * scene.structure_k * res.x[k] ** 2
                + 0.5 * scene.ice_M * res.w[k] ** 2)

    change = energy(-1) - energy(0)
    ledger = drag_work - damping_loss - impact_loss
    scale = max(abs(drag_work), damping_loss, impact_loss, abs(change))
    assert abs(change - ledger) <= 1e-6 * scale, (change, ledger)


def test_impulse_equals_ice_momentum_balance():
    """Impulse on the structure (impacts + sticking contact) = drag impulse on the ice - M dw."""
    scene = Scene(impact_e=0.3)
    t_end = 30.0
    first = run(scene, t_end)
    assert first.sticking_since is not None  # the check must cover a sticking phase
    t, wts = _gauss_times(first.impacts["t"], t_end)
    res = run(scene, t_end, sample_times=np.append(t, t_end))
    drag_impulse = np.sum(wts * _drag_force(scene, res.w[1:-1], scene.flow_u))
    expected = drag_impulse - scene.ice_M * (res.w[-1] - res.w[0])
    assert np.sum(res.impulse) == pytest.approx(expected, rel=1e-8)
    assert np.sum(res.impulse) > np.sum(res.impacts["impulse"])  # sticking pushes too


# --- cross-check against an independent solve_ivp integration -----------------------------------

def test_first_20_impacts_match_ode_figure2():
    ref = ode_simulate(FIG2, 200.0, max_impacts=20, rtol=1e-13, atol=1e-16)
    exact = run(FIG2, float(ref["t"][-1]) + 0.5).impacts
    assert len(ref["t"]) == 20
    assert np.max(np.abs(exact["t"][:20] - ref["t"])) < 1e-8


@pytest.mark.parametrize("name,n_global", [("quadratic", 12), ("M400_e0.8", 4)])
def test_impacts_match_ode_within_sensitivity(name, n_global):
    """Globally the first impacts agree within 1e-8 s until the motion's own sensitivity (see
    test_sensitivity_limits_global_agreement) amplifies the ODE's 1e-12 local errors; segment by
    segment, restarted from the exact solver's post-impact state, all 20 agree within 1e-9 s."""
    scene = SCENES[name]
    exact = run(scene, 40.0).impacts
    ref = ode_simulate(scene, 40.0, max_impacts=n_global, rtol=1e-13, atol=1e-16)
    assert np.max(np.abs(exact["t"][:n_global] - ref["t"])) < 1e-8
    for i in range(min(20, len(exact) - 1)):
        if exact["restitution"][i] == 0.0:
            break  # the bodies stick: the ODE reference does not model that
        y0 = [exact["x"][i], exact["v_plus"][i], exact["x"][i], exact["w_plus"][i]]
        nxt = ode_simulate(scene, exact["t"][i] + 50.0, max_impacts=1, t0=exact["t"][i], y0=y0)
        assert len(nxt["t"]) == 1
        assert abs(nxt["t"][0] - exact["t"][i + 1]) < 1e-9, i


def test_sensitivity_limits_global_agreement():
    """The motion amplifies a 1e-13 relative change of the initial ice velocity by more than 1e4
    within 20 impacts, so no integrator with 1e-12 local error can agree to 1e-8 s that far."""
    for scene in (QUAD, HEAVY_LIGHT):
        a = run(scene, 40.0).impacts["t"][:20]
        b = run(scene.replace(ice_v0=scene.ice_v0 * (1 + 1e-13)), 40.0).impacts["t"][:20]
        assert abs(b[0] - a[0]) < 1e-12
        assert np.max(np.abs(b - a)) > 1e-8


# --- grazing ------------------------------------------------------------------------------------

def _grazing_scene(margin):
    """Undamped structure swinging with amplitude X = 1 mm, ice at rest (no drag) at -X + margin:
    margin > 0 is a touch lasting ~ 2 sqrt(2 margin / X) / wn, margin < 0 a near miss."""
    wn, amplitude = 25.0, 1e-3
    return Scene(structure_c=0.0, structure_v0=amplitude * wn, ice_Cd=0.0, ice_v0=0.0,
                 ice_z0=-amplitude + margin, flow_u=0.0)


def test_grazing_touch_is_found():
    scene = _grazing_scene(1e-12)
    # a 0.1 ms sampling of the gap sees no contact: both roots fall between two samples
    t = np.arange(0.0, 0.3, 1e-4)
    gap = 1e-3 * np.sin(25.0 * t) - scene.ice_z0
    assert gap.min() > 0.0
    res = run(scene, 0.3)
    assert len(res.impacts) == 1
    t_touch = 3 * math.pi / 2 / 25.0
    assert abs(res.impacts["t"][0] - t_touch) < 2 * math.sqrt(2e-12 / 1e-3) / 25.0
    assert 0 < res.impacts["w_minus"][0] - res.impacts["v_minus"][0] < 1e-5


def test_near_miss_is_not_a_touch():
    res = run(_grazing_scene(-1e-12), 0.3)
    assert len(res.impacts) == 0
    assert res.gap.min() > 0.0


@pytest.mark.parametrize("drag_model", [1, 2])
def test_flight_clearance_proves_the_gap_open(drag_model):
    """A flight's envelope clearance: with the ice upstream of the structure's reach, a span
    over which the gap stays open (checked on a dense grid of the closed forms, and against the
    envelope margin computed here: offset - amplitude - z over the bound max(w, u, 0) on the
    ice's speed); with the ice at or past the structure's equilibrium, nothing (0)."""
    from iceimpact.solvers.exact import EventSolver, Flight

    solver = EventSolver(Scene(structure_k=1e9, drag_model=drag_model))
    omega = math.sqrt(1e9 / 1600.0)
    x0, v0, z0, w0, u = 1e-3, 0.3, -6e-3, 0.05, 0.1
    flight = Flight(solver.context, 0.0, x0, v0, z0, w0, u)
    span = flight.clearance(0.0)
    reach = math.sqrt(x0 * x0 + v0 * v0 / omega ** 2)  # energy bound of the free structure
    assert span == pytest.approx((0.0 - reach - z0) / max(w0, u), rel=1e-9)
    tau = np.linspace(0.0, span, 200001)
    x, _, z, _ = flight.state_array(flight.anchor(), tau)
    assert np.all(x - z > 0.0)
    assert np.min(x - z) < 0.5 * (x0 - z0)  # the span is not trivially short
    # later in the flight, from its state there
    x1, v1, z1, w1 = flight.state(0.5 * span)
    later = flight.clearance(0.5 * span)
    assert later == pytest.approx((-math.sqrt(x1 * x1 + v1 * v1 / omega ** 2) - z1)
                                  / max(w1, u), rel=1e-9)
    # the ice at or past the equilibrium (x = 0): the envelope proves nothing
    for z_at in (0.0, 5e-4):
        assert Flight(solver.context, 0.0, 2e-3, v0, z_at, w0, u).clearance(0.0) == 0.0


# --- stepping ------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", ["fig2", "quadratic", "e0.5", "quad_e0.5"])
def test_result_does_not_depend_on_communication_step(name):
    scene = SCENES[name]
    ref = run(scene, 12.0).impacts["t"]
    for h in (1e-3, 1e-3 / 7, 0.37):
        sim = Simulator(scene)
        while sim.t < 12.0 - 1e-9:
            sim.advance(h)
        got = np.array([i.t for i in sim.impacts])
        assert len(got) == len(ref)
        assert np.max(np.abs(got - ref)) < 1e-12


# --- sticking, separation, Zeno and chatter -------------------------------------------------------

@pytest.mark.parametrize("drag_model", [1, 2])
def test_plastic_impact_sticks_and_settles(drag_model):
    """With e = 0 each impact sticks; the structure's swing pulls it off the ice again a few times
    (contact force turning tensile) until the bodies stay together at k x = drag (eq. 28-29)."""
    scene = Scene(impact_e=0.0, drag_model=drag_model)
    sim = Simulator(scene)
    reports = [sim.advance(0.01) for _ in range(6000)]
    assert sim.solver.sticking
    assert all(i.restitution == 0.0 for i in sim.impacts)
    assert 1 < len(sim.impacts) < 100
    assert sim.solver.sticking_since < 20.0
    stuck = [r for r in reports if r.sticking]
    assert all(r.gap == 0.0 and r.x == r.z and r.v == r.w for r in stuck)
    assert all(r.impulse >= 0.0 for r in stuck)  # compressive contact force only
    B = 0.5 * scene.fluid_rho * scene.ice_Cd * scene.ice_A
    push = B * scene.drag_v_lin * scene.flow_u if drag_model == 1 else B * scene.flow_u ** 2
    # lightly damped combined oscillation about the equilibrium of eq. 28-29
    last = reports[-2000:]
    assert np.mean([r.x for r in last]) == pytest.approx(push / scene.structure_k, rel=2e-2)
    assert np.mean([r.force for r in last]) == pytest.approx(push, rel=2e-2)


@pytest.mark.parametrize("drag_model", [1, 2])
def test_flow_reversal_separates_the_bodies(drag_model):
    sim = Simulator(Scene(impact_e=0.0, drag_model=drag_model))
    for _ in range(3000):
        sim.advance(0.01, 0.1)
    assert sim.report.sticking
    for _ in range(300):
        rep = sim.advance(0.01, -0.1)
    assert not rep.sticking
    assert rep.gap > 1e-4 and rep.w < 0.0


@pytest.mark.parametrize("w0,kind", [(0.05, "impact"), (-0.05, "flight"), (0.0, "stick")])
def test_ice_starting_in_contact(w0, kind):
    scene = Scene(ice_z0=0.0, ice_v0=w0, impact_e=0.5)
    sim = Simulator(scene)
    rep = sim.advance(1e-3)
    if kind == "impact":
        assert sim.impacts[0].t == 0.0 and rep.impacts == 1
        assert rep.impulse == pytest.approx(scene.structure_m * sim.impacts[0].v_plus)
    elif kind == "flight":
        assert rep.impacts == 0 and rep.gap > 0
    else:
        assert rep.sticking and rep.gap == 0.0


