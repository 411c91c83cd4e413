"""The contact rules every method shares (iceimpact.solvers.contact_rules): the chatter and Zeno
closure, degenerate contacts, the one-call contact of a flight's end, the contact right after an
impact. Each rule is tested through the method that applies it (the exact method, and the ODE
method where its policy differs)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from iceimpact import Scene, Simulator, run
from iceimpact.fmi.adapter import FmuModel
from iceimpact.scene import METHOD_ODE
from iceimpact.simulator import make_solver
from iceimpact.solvers.ode import OdeSolver
from scenes import ELASTIC_CHATTER, toggled_flow

FIG2 = Scene()
FIG8 = Scene(impact_e=0.5)
FIG13 = Scene(ice_A=2.0, drag_model=2)


def ode(scene: Scene, rtol: float, method: int = 2) -> Scene:
    return scene.replace(solver_method=METHOD_ODE, solver_rtol=rtol, solver_ode_method=method)


# the search's seed-41 scene (method 1): a 1.4 kg ice at e = 1 pressed by its drag on a light,
# undamped structure; here at omega_n = 1e4 rad/s instead of 1e6 (the work scales with omega_n)
@pytest.mark.parametrize("e,t_end", [(0.5, 30.0), (0.9, 60.0), (0.99, 150.0)])
def test_zeno_sequence_closes_with_bounded_work(e, t_end):
    res = run(Scene(impact_e=e), t_end)
    assert res.sticking_since is not None
    assert len(res.impacts) < 3000
    assert res.impacts["restitution"][-1] == 0.0


def test_elastic_chatter_is_bounded():
    """With e = 1 the exact model chatters ever faster (impact rate doubling every ~25 s);
    the chatter closure keeps the 400 s Figure 2 run to a bounded number of impacts."""
    res = run(FIG2, 400.0, dt=0.05)
    assert len(res.impacts) < 50_000
    assert np.all(np.isfinite(res.x)) and res.gap.min() >= -1e-12


# Degenerate contacts found by the property test: zero closing speed to rounding, contact force
# vanishing to rounding right after a separation, exact tangency of an undamped structure, drag
# far below rounding. Each once looped without end; each must finish with sound outputs.
DEGENERATE = [
    dict(structure_m=10.0, structure_c=0.0, structure_k=10.0, structure_v0=0.0, ice_M=10.0,
         ice_Cd=0.0, ice_z0=0.0, ice_v0=0.0, impact_e=0.0, flow_u=0.0),
    dict(structure_m=182.97919098315285, structure_c=66962.76866569826,
         structure_k=6126396.618220742, ice_M=1.8297919098315285, ice_A=3.4635181522065186,
         ice_Cd=0.5, ice_z0=-0.01, ice_v0=0.5, impact_e=0.0, flow_u=0.0),
    dict(structure_m=97309.12714773905, structure_c=52044408.37315177,
         structure_k=6958803665.968151, structure_x0=0.0031553379301433385,
         structure_v0=0.032399444595779925, ice_M=3137064.4243700416, ice_A=9.924986566308483,
         ice_Cd=1.4376295694872663, ice_z0=-0.02287382259996331, ice_v0=0.15180276292023098,
         impact_e=0.7795916723849599, flow_u=0.4196769402612454),
    dict(structure_m=10.0, structure_c=0.0, structure_k=301305.01814207697,
         structure_x0=-0.008698303756774384, ice_M=0.14507538403378428, ice_A=8.66120444193421,
         ice_Cd=0.014507538403378428, ice_z0=-0.013087032715706316,
         ice_v0=0.014507538403378428, impact_e=0.004388728958931932, flow_u=0.864408078865055),
    dict(structure_m=42241.85370594951, structure_c=0.0, structure_k=58833372.69716639,
         structure_x0=-0.007049025303708411, ice_M=422.41853705949507, ice_A=9.177955034552364,
         ice_Cd=0.0, ice_z0=-0.007049025303708411, ice_v0=0.0, impact_e=0.28260704402227216,
         drag_model=2, flow_u=0.4407499115489842),
    dict(structure_m=10.0, structure_c=1727.5, structure_k=74606.40625,
         structure_x0=0.0031681944612205835, structure_v0=4.831371188027306e-70, ice_M=10.0,
         ice_Cd=0.0, ice_z0=0.0031681944612205835, ice_v0=0.0, impact_e=0.0, flow_u=0.0),
    dict(structure_m=10.0, structure_c=0.0, structure_k=27992.822897126796, ice_M=529.0824406189153,
         ice_A=8.278598598463518, ice_Cd=8.143817604372124e-17, ice_z0=-1.401298464324817e-45,
         ice_v0=0.0, impact_e=0.0, flow_u=0.16558793959893686),
    dict(structure_m=10.0, structure_c=3.017796921041186e-18, structure_k=2.637082410600901,
         structure_x0=0.002130621631778318, structure_v0=-0.004502401310002541,
         ice_M=41.83693608850292, ice_A=7.089538104910952, ice_Cd=1.8736018314044691,
         ice_z0=-0.04281886921978263, ice_v0=0.37969179098001243, impact_e=0.45363873783994013,
         drag_model=2, flow_u=0.6903960901809159),
]


@pytest.mark.parametrize("params", DEGENERATE, ids=range(len(DEGENERATE)))
def test_degenerate_contacts_finish(params):
    sim = Simulator(Scene(**params))
    reports = [sim.advance(0.01) for _ in range(300)]
    values = np.array([[r.x, r.v, r.z, r.w, r.gap, r.impulse] for r in reports])
    assert np.all(np.isfinite(values))
    assert min(r.x - r.z for r in reports) >= -1e-12
    assert all(i.w_minus - i.v_minus >= 0.0 for i in sim.impacts)


@pytest.mark.parametrize("e", [1.0, 0.6, 0.0])
def test_impact_at_contact_decides_as_at_contact_then_impact(e):
    """The one-call contact of a flight's end gives at_contact's decisions to the bit: an impact
    exactly when at_contact says IMPACT (never at a closing speed at rounding level), the same
    impact step, and ``parts`` exactly when at_contact, asked after it, says FLIGHT with an
    opening speed (not after a plastic or chatter-closing impact, nor a rounding-level one)."""
    from iceimpact.solvers.contact_rules import Outcome
    from iceimpact.solvers.exact import EventSolver
    solver = EventSolver(Scene())
    rules = solver.rules
    u = solver.u
    rng = np.random.default_rng(7)
    x_values = [0.0, 1e-4, -3e-3, 0.02]
    cases = [(x, v, w) for x in x_values
             for v, w in [(0.0, 0.5), (-0.2, 0.3), (0.1, 0.1), (0.1, 0.1 + 1e-17),
                          (0.1, 0.1 - 1e-17), (0.3, -0.1), (0.0, 1e-13), (0.0, 3e-9)]]
    cases += [tuple(rng.normal(0.0, [0.01, 0.3, 0.3])) for _ in range(200)]
    seen = set()
    for x, v, w in cases:
        impact, parts = rules.impact_at_contact(1.0, x, v, w, e, u)
        before = rules.at_contact(1.0, x, v, w, u)
        assert (impact is not None) == (before.outcome is Outcome.IMPACT)
        if impact is None:
            assert not parts
            seen.add("none")
            continue
        assert impact == rules.impact(1.0, x, before.v, before.w, e, u)
        after = rules.at_contact(1.0, x, impact.v_plus, impact.w_plus, u)
        assert parts == (after.outcome is Outcome.FLIGHT and after.v - after.w > 0.0)
        seen.add(parts)
    assert {"none", e > 0.0} <= seen  # (e > 0: chatter closure gives False cases as well)
    assert e > 0.0 or True not in seen


def test_ode_zeno_sequence_closes_and_sticks():
    """Figure 8 (e = 0.5): the bounces shrink, the sequence is closed by one plastic impact and
    the bodies stick at the exact solver's time (to 2.4e-8 s at rtol 1e-12); sticking carries
    the contact force b u."""
    exact = make_solver(FIG8)
    exact.advance_to(12.0, FIG8.flow_u)
    solver = OdeSolver(ode(FIG8, 1e-12))
    solver.advance_to(12.0, FIG8.flow_u)
    assert solver.sticking and exact.sticking
    assert solver.sticking_since == pytest.approx(exact.sticking_since, abs=1e-6)
    assert solver.impacts[-1].restitution == 0.0
    solver.advance_to(100.0, FIG8.flow_u)
    exact.advance_to(100.0, FIG8.flow_u)
    assert solver.sticking

    def real(impacts):  # the bounces both resolve: method 3 closes a sequence once its
        # bounces are no higher than its positions' noise (here closing at ~1e-8 m/s)
        return [i.t for i in impacts if i.approach_speed > 1e-7]

    assert real(solver.impacts) == pytest.approx(real(exact.impacts), abs=1e-6)
    assert solver.state.x == pytest.approx(exact.state.x, rel=1e-5)
    u = FIG8.flow_u
    assert solver.advance_to(101.0, u) == pytest.approx(exact.advance_to(101.0, u), rel=1e-5)


def test_ode_work_is_bounded_in_elastic_chatter():
    """e = 1, Figure 13 over 100 s: the exact solver closes several hundred chatter sequences;
    the ODE must do the same with bounded work, not step through ever shorter bounces."""
    solver = OdeSolver(ode(FIG13, 1e-6))
    solver.advance_to(100.0, FIG13.flow_u)
    assert 100 < len(solver.impacts) < 5000
    assert solver.nfev < 2_000_000


def test_the_chatter_threshold_trades_impacts_for_nothing_a_design_sees():
    """solver.chatter_fraction (docs/explanation/accuracy.md, "The chatter threshold"): Figure 2
    over 400 s at 1e-1 and at 1e-4 of the period. The finer threshold resolves the elastic
    chatter ~580 times longer in impacts (364 against 209,758; the bodies stick at 167 s, and
    not by 400 s), while the RMS of k x moves by 3.4e-4, its peak not at all and its DELs by at
    most 1.3e-5."""
    from iceimpact.studies.loads import run_loads

    coarse, fine = (run(Scene(solver_chatter_fraction=f), 400.0, dt=1e-3) for f in (1e-1, 1e-4))
    assert len(fine.impacts) > 500 * len(coarse.impacts)
    assert coarse.sticking_since < 200.0 and fine.sticking_since is None
    k = FIG2.structure_k
    rms = [float(np.sqrt(np.mean((k * r.x) ** 2))) for r in (coarse, fine)]
    assert 1e-5 < abs(rms[0] / rms[1] - 1.0) < 1e-3
    assert np.max(np.abs(coarse.x)) == np.max(np.abs(fine.x))
    dels = [run_loads(r).del_1hz for r in (coarse, fine)]
    assert all(abs(dels[0][m] / dels[1][m] - 1.0) < 1e-4 for m in dels[0])


def test_chatter_fraction_is_checked_and_reaches_both_methods():
    """A value outside [1e-6, 0.5] is refused naming the parameter, the value and the range; a
    valid one sets the chatter time of methods 1 and 3 (no module constant read)."""
    from iceimpact import ParameterError

    for bad in (0.0, 1e-7, 0.6, math.nan):
        with pytest.raises(ParameterError, match=r"solver.chatter_fraction = .* "
                                                 r"1e-6 <= chatter_fraction <= 0.5"):
            Scene(solver_chatter_fraction=bad)
    for method in (1, 3):
        solver = make_solver(Scene(solver_method=method, solver_chatter_fraction=0.25))
        assert solver.rules.chatter_time == pytest.approx(0.25 * 2.0 * math.pi / FIG2.omega_n)


def test_an_elastic_chatter_at_a_stiff_structure_is_bounded_by_the_chatter_time():
    """Pressed by the drag, an elastic (e = 1) ice makes ever shorter bounces on the structure
    as the drag drains their energy: the exact method resolves each until a bounce would be
    shorter than the chatter time (solver.chatter_fraction of the structure's period), then the
    bodies stick. So the impacts of any window are at most its length over the chatter time
    (the rate reaches ~0.9 of it), the chatter ends, and its total is ~0.1 omega_n impacts
    (9,894 at 1e4 rad/s, 107,737 at 1e5): the work docs/explanation/robustness/stiff-structures.md
    bounds."""
    from iceimpact.solvers.contact_rules import chatter_time

    scene = Scene(**ELASTIC_CHATTER)
    cap = 0.01 / chatter_time(math.sqrt(scene.structure_k / scene.structure_m),
                              scene.solver_chatter_fraction)
    sim = Simulator(scene)
    rates = []
    while sim.t < 3.0 - 1e-12:
        before = sim.impact_count
        sim.advance(0.01, 0.1)
        rates.append(sim.impact_count - before)
    assert max(rates) <= cap + 1.0
    assert max(rates) >= 0.5 * cap  # the bound is the one that binds
    assert rates[-50:] == [0] * 50  # stuck: the chatter has ended
    s = sim.solver.state
    assert s.x == s.z and s.v == s.w
    assert 5e3 < sim.impact_count < 2e4


@pytest.mark.parametrize("method", [1, 3])
def test_the_contact_after_an_impact_is_not_a_degenerate_contact(monkeypatch, method):
    """The light floe bouncing near the explicit rate limit (0.34 mg on a 1.8 g structure, e = 0.7,
    the flow reversed one 1 ms
    step in four): every 4 ms the returning floe's impact is closed plastically (chatter
    closure), and the contact right after it, at equal velocities, was counted as a contact
    re-forming with no speed. From the ninth within the chatter time (0.39 s) the bodies were
    held for up to that long with no look for a separation (742 holds in method 1's 3 s, 259 in
    method 3's 1 s, at 1 ms steps; here method 3 runs 0.05 s at 0.1 ms steps). The contact after
    an impact is no longer counted: no hold, the same impacts, a sound run."""
    from iceimpact.solvers import contact_rules
    from random_search import replay

    holds = []
    original = contact_rules.DegenerateContacts.hold

    def counted(self, t):
        hold = original(self, t)
        if hold > 0.0:
            holds.append(t)
        return hold

    monkeypatch.setattr(contact_rules.DegenerateContacts, "hold", counted)
    scene = dict(structure_m=0.0018329234721427574, structure_c=0.0005841447487010957,
                 structure_k=4.654109849934993e-05, structure_x0=4.177705884955332e-267,
                 structure_v0=1e-16, ice_M=3.3519054173469566e-07, ice_A=0.19282973629443662,
                 ice_Cd=0.5503080240880754, ice_z0=4.177705884955332e-267,
                 ice_v0=-0.00013118567765448426, impact_e=0.7045244644744516, drag_model=1,
                 drag_v_lin=0.0018488068422214442, solver_method=method)
    h = 1e-3 if method == 1 else 1e-4  # method 3: 0.05 s at 0.1 ms steps (the search's horizon)
    outcome = replay({"scene": scene, "h": h, "flow": "reversed 1 in 4", "signs": [True],
                      "time_limit": 60.0})
    assert outcome.fault is None and not outcome.refused
    assert outcome.impacts > 10
    assert holds == []


# --- a contact only pushes -----------------------------------------------------------------------
#: the ice resting on the structure (Figure 2 scene otherwise)
RESTING = {"structure_x0": 0.0, "ice_z0": 0.0, "ice_v0": 0.0}


@pytest.mark.parametrize("method", [1, 2, 3])
@pytest.mark.parametrize("h", [1e-4, 5e-4])
def test_a_contact_never_pulls(method, h):
    """With the flow turning, the bodies separate: no step's contact impulse is tensile (the
    degenerate-contact hold used to count each re-anchor at a flow change as a contact
    re-forming and then held the bodies together against the drag)."""
    for drag in (1, 2):
        sim = Simulator(Scene(**RESTING, drag_model=drag, solver_method=method,
                              solver_detection=2))
        steps = 40 if method == 3 else 400
        for i in range(steps):
            r = sim.advance(h, toggled_flow(i))
            assert r.impulse >= 0.0, (i, r)
            if i % 4 == 3 and method != 2:  # the drag pulls the ice away: the bodies part
                assert not r.sticking, (i, r)
            assert r.gap >= 0.0


def test_a_reversed_flow_does_not_pin_method_2():
    """Method 2's steady state (eq. 27-29) presses the ice on the structure with F = b u: with
    u < 0 it would pull, so the ice drifts away instead."""
    for drag in (1, 2):
        sim = Simulator(Scene(**RESTING, drag_model=drag, solver_method=2, flow_u=-1e-5))
        for _ in range(50):
            r = sim.advance(0.1)
            assert r.impulse >= 0.0 and not r.sticking
        assert sim.solver.state.z < 0.0


def test_a_contact_never_pulls_through_the_fmu():
    logs: list[str] = []
    for method in (1, 3):
        fmu = FmuModel(lambda status, text: logs.append(text))
        for name, value in {"structure.x0": 0.0, "ice.z0": 0.0, "ice.v0": 0.0,
                            "solver.method": method}.items():
            fmu.set(name, value)
        assert fmu.initialize()
        t = 0.0
        for i in range(40 if method == 3 else 80):
            fmu.set("flow.u", toggled_flow(i))
            assert fmu.do_step(t, 5e-4)
            t += 5e-4
            assert fmu.get("contact.impulse") >= 0.0
            assert fmu.get("contact.force") >= 0.0
        assert not logs
