"""Method 1 with the modal structure (solvers/exact/modal.py): what must hold whatever the
modes, checked against the SDOF solver, which shares none of the modal segments' code."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import random_scenes
from iceimpact import Scene, run
from iceimpact.simulator import Simulator
from iceimpact.solvers.exact import bounces
from iceimpact.solvers.exact.modal import ModalBounceMarch, ModalRide, ModalSolver
from modal_reference import MODAL_SCENES, MODAL_T_END, simulate

SDOF = Scene()
F1 = SDOF.omega_n / (2.0 * math.pi)
ZETA1 = SDOF.zeta
#: The SDOF scenes compared with their modal twins: plain, riding, Zeno, quadratic drag,
#: over-damped (windows short of where a chaotic scene amplifies rounding)
SCENES = {
    "bounces": (dict(drag_model=2, flow_u=0.3, ice_M=1200.0, impact_e=0.7), 10.0),
    "riding": (dict(impact_e=0.0, flow_u=0.3), 20.0),
    "zeno": (dict(impact_e=0.5, drag_model=2, flow_u=0.5, ice_M=800.0), 20.0),
    "quadratic riding": (dict(impact_e=0.0, drag_model=2, flow_u=0.2), 20.0),
    "over-damped": (dict(structure_c=2e5, impact_e=0.3, flow_u=0.3), 20.0),
    "article": (dict(), 60.0),
}


def _one_mode(sdof: Scene, **modal) -> Scene:
    """The SDOF (m, c, k, x0, v0) of ``sdof`` as mode 1 of the modal structure."""
    f = math.sqrt(sdof.structure_k / sdof.structure_m) / (2.0 * math.pi)
    zeta = sdof.structure_c / (2.0 * math.sqrt(sdof.structure_k * sdof.structure_m))
    return sdof.replace(structure_model=3, structure_mode1_f=f, structure_mode1_zeta=zeta,
                        structure_mode1_m=sdof.structure_m, structure_mode1_q0=sdof.structure_x0,
                        structure_mode1_v0=sdof.structure_v0, **modal)


def _assert_same_impacts(a, b, time_tol=1e-9, impulse_rtol=1e-6):
    ia, ib = a.impacts, b.impacts
    assert len(ia) == len(ib)
    np.testing.assert_allclose(ib["t"], ia["t"], rtol=0, atol=time_tol)
    np.testing.assert_allclose(ib["impulse"], ia["impulse"], rtol=impulse_rtol,
                               atol=1e-12 * np.max(np.abs(ia["impulse"]), initial=0.0))
    np.testing.assert_array_equal(a.sticking, b.sticking)
    np.testing.assert_allclose(b.x, a.x, rtol=0, atol=1e-9 * np.max(np.abs(a.x)))


@pytest.mark.parametrize("name", SCENES)
def test_a_second_mode_the_contact_point_does_not_see_changes_nothing(name):
    kw, t_end = SCENES[name]
    sdof = Scene(**kw)
    modal = _one_mode(sdof, structure_modes=2, structure_mode2_f=11.0, structure_mode2_phi=0.0,
                      structure_mode2_q0=1e-3)
    _assert_same_impacts(run(sdof, t_end), run(modal, t_end))


@pytest.mark.parametrize("name", ["bounces", "riding", "quadratic riding"])
def test_two_identical_modes_of_half_the_modal_mass_are_one_mode(name):
    """Mode 1 split in two equal halves, each of mass m/2 and phi = 1/2 (sum phi^2/m_k = 1/m):
    the halves move together, their sum is the one mode."""
    kw, t_end = SCENES[name]
    one = _one_mode(Scene(**kw))
    halves = one.replace(structure_modes=2, structure_mode1_m=800.0, structure_mode1_phi=0.5,
                         structure_mode2_f=F1, structure_mode2_zeta=ZETA1,
                         structure_mode2_m=800.0, structure_mode2_phi=0.5)
    _assert_same_impacts(run(one, t_end), run(halves, t_end))


def test_a_held_load_offsets_its_mode_by_l_over_k():
    """Ice far upstream under no flow: mode 1 settles at L / k_1 (400 s: 25 decay times), mode 2
    at its own."""
    scene = Scene(structure_model=3, structure_modes=2, structure_mode2_f=11.0,
                  structure_mode2_zeta=0.05, structure_mode2_phi=0.6, flow_u=0.0, ice_v0=0.0,
                  ice_z0=-10.0)
    loads = (2.0e3, -500.0)
    sim = Simulator(scene)
    for _ in range(200):
        report = sim.advance(2.0, loads=loads)
    k1 = 1600.0 * (2 * math.pi * F1) ** 2
    k2 = 1600.0 * (2 * math.pi * 11.0) ** 2
    assert report.mode1_q == pytest.approx(loads[0] / k1, rel=1e-6)
    assert report.mode2_q == pytest.approx(loads[1] / k2, rel=1e-6)
    assert report.x == pytest.approx(loads[0] / k1 + 0.6 * loads[1] / k2, rel=1e-6)
    assert report.impact_count == 0


def test_a_saved_state_continues_identically_in_flight_and_while_riding():
    scene = Scene(structure_model=3, structure_modes=2, structure_mode2_f=11.0,
                  structure_mode2_zeta=0.02, structure_mode2_phi=0.6, impact_e=0.0,
                  drag_model=2, flow_u=0.3, ice_M=1200.0)
    sim = Simulator(scene)
    phases = set()
    for i in range(6000):
        loads = (800.0 * math.sin(2 * math.pi * 0.3 * i * 1e-3), 0.0)
        sim.advance(1e-3, loads=loads)
        if i % 700 == 0:
            copy = Simulator.from_snapshot(json.loads(json.dumps(sim.save())))
            phases.add(sim.sticking)
            for j in range(i + 1, i + 300):
                later = (800.0 * math.sin(2 * math.pi * 0.3 * j * 1e-3), 0.0)
                assert copy.advance(1e-3, loads=later) == _peek(sim, later)
            sim = copy
    assert phases == {True, False}


def _peek(sim: Simulator, loads) -> object:
    return sim.advance(1e-3, loads=loads)


def test_a_load_of_the_wrong_length_is_refused_and_changes_nothing():
    sim = Simulator(Scene(structure_model=3, structure_modes=2, structure_mode2_phi=0.5))
    before = sim.save()
    with pytest.raises(Exception, match="one value \\(N\\) per mode used"):
        sim.advance(1e-3, loads=(1.0,))
    with pytest.raises(Exception, match="structure.mode2.load"):
        sim.advance(1e-3, loads=(1.0, math.nan))
    assert sim.save() == before


# against the independent reference (tests/modal_reference.py: DOP853 at rtol 1e-12, impact by
# impact) ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", list(MODAL_SCENES))
def test_impacts_and_motion_match_the_independent_reference(name):
    """Two under-damped modes, an over-damped one, riding phases that end, quadratic drag:
    impact times within 1e-8 s, impulses within 1e-8, the contact point within 1e-9 m at the
    samples and the riding flags equal away from the phase boundaries."""
    kw, t_end = MODAL_SCENES[name], MODAL_T_END[name]
    dt = 1e-3
    times = np.arange(1, int(round(t_end / dt)) + 1) * dt
    ref = simulate(kw, t_end, sample_times=times)
    result = run(Scene(**kw), t_end, dt=dt)
    impacts = result.impacts
    assert len(impacts) == len(ref.impacts)
    np.testing.assert_allclose(impacts["t"], [i.t for i in ref.impacts], rtol=0, atol=1e-8)
    np.testing.assert_allclose(impacts["impulse"], [i.impulse for i in ref.impacts], rtol=1e-8)
    np.testing.assert_allclose(result.x[1:], ref.x, rtol=0, atol=1e-9)
    boundaries = np.array([t for phase in ref.riding for t in phase if math.isfinite(t)])
    away = (np.min(np.abs(times[:, None] - boundaries[None, :]), axis=1) > 1e-3
            if boundaries.size else np.ones(times.size, dtype=bool))
    np.testing.assert_array_equal(result.sticking[1:][away], ref.ride[away])
    if name == "sticking":
        assert len(ref.riding) == 7 and result.sticking.any()


@pytest.mark.parametrize("name", ["two_underdamped", "overdamped_mode", "sticking", "quadratic"])
def test_loads_changing_linearly_match_the_reference(name):
    """Loads L_k + R_k t on both modes (flights about moving particular solutions, riding steps
    with the load's rate): the impacts of the independent reference, within 1e-8 s and 1e-8
    (the over-damped scene amplifies any difference tenfold an impact: its first four)."""
    kw, t_end = MODAL_SCENES[name], MODAL_T_END[name]
    loads, rates = np.array([300.0, -200.0]), np.array([4000.0, 1500.0])
    ref = simulate(kw, t_end, loads=lambda t: loads + rates * t)
    sim = Simulator(Scene(**kw))
    sim.advance_to(t_end, loads=tuple(loads), load_rates=tuple(rates))
    impacts = list(sim.impacts)
    count = 4 if name == "overdamped_mode" else len(ref.impacts)
    assert len(impacts) == len(ref.impacts) >= count
    np.testing.assert_allclose([i.t for i in impacts[:count]],
                               [i.t for i in ref.impacts[:count]], rtol=0, atol=1e-8)
    np.testing.assert_allclose([i.impulse for i in impacts[:count]],
                               [i.impulse for i in ref.impacts[:count]], rtol=1e-8)


# the compiled march of bounces on the modes ----------------------------------------------------
#: Figure 2's scene with a second mode (bouncing faster and faster up to 54 s, then the ice
#: rides), and a third, over-damped mode under the linear drag (bouncing from 5 to 10 s); each
#: with a time where it bounces often
MARCH_SCENES = {
    "two modes": (dict(structure_model=3, structure_modes=2, structure_mode2_f=11.0,
                       structure_mode2_zeta=0.02, structure_mode2_phi=0.6), 48.0),
    "over-damped third mode, linear drag": (dict(
        structure_model=3, structure_modes=3, structure_mode2_f=4.0, structure_mode2_zeta=1.5,
        structure_mode2_phi=0.5, structure_mode3_f=20.0, structure_mode3_zeta=0.01,
        structure_mode3_phi=-0.3, drag_model=1, impact_e=0.7), 5.0),
}
compiled_only = pytest.mark.skipif(bounces.modal_kernel() is None,
                                   reason="numba absent or ICEIMPACT_PURE set: no compiled march")


@pytest.mark.parametrize("name", MARCH_SCENES)
def test_the_march_of_bounces_on_the_modes_run_as_python_is_the_python_march(name):
    """bounce_march on the modes' functions (MODAL_MARCH), run as Python: the numbers of
    ModalFlight, the contact rules and the solver's modal state, to the bit, so what numba
    compiles is that march, whether or not numba is installed."""
    fields, start = MARCH_SCENES[name]
    impacts = random_scenes.kernel_is_the_python_march(
        Scene(**fields), start, bounces.MODAL_MARCH, 2.0,
        np.linspace(start + 2.6, start + 4.0, 57), march=ModalBounceMarch)
    assert impacts > 10


@compiled_only
@pytest.mark.parametrize("name", MARCH_SCENES)
def test_the_compiled_march_on_the_modes_is_the_python_march(name):
    """The compiled march (which the simulator takes where numba is) against the Python march
    alone: the same impacts, samples and modal states, to the bit."""
    fields, start = MARCH_SCENES[name]
    scene = Scene(**fields)
    impacts = random_scenes.kernel_is_the_python_march(
        scene, start, bounces.modal_kernel(), 2.0, np.linspace(start + 2.6, start + 4.0, 57),
        march=ModalBounceMarch)
    assert impacts > 10
    compiled, python = run(scene, 60.0), _python_march(lambda: run(scene, 60.0))
    for key in ("x", "v", "z", "w", "impulse", "sticking", "modes_q", "modes_v"):
        assert getattr(compiled, key).tobytes() == getattr(python, key).tobytes(), key
    assert compiled.impacts.tobytes() == python.impacts.tobytes()


def _python_march(call):
    """``call()`` with the modal solver's compiled march off."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(ModalSolver, "_bounce_march", lambda self: None)
        return call()


@compiled_only
def test_the_compiled_march_takes_loads_that_change_linearly():
    """Loads with rates set at every step (the FMU's linear extrapolation), stepped with and
    without early return: each step's state, impulse, impact count and modal state are the
    Python march's, to the bit."""
    scene = Scene(**MARCH_SCENES["two modes"][0])

    def steps():
        rows = []
        sim = Simulator(scene)
        for i in range(5500):
            t = 0.01 * i
            loads = [3000.0 * math.sin(0.3 * t), 400.0 * math.cos(2.0 * t)]
            rates = [900.0 * math.cos(0.3 * t), -800.0 * math.sin(2.0 * t)]
            report = sim.advance(0.01, loads=loads, load_rates=rates, stop_at_event=i % 4 == 0)
            q, p = sim.solver.modal_state()
            rows.append([float(value).hex() for value in (report.t, report.x, report.v,
                                                          report.z, report.w, report.impulse,
                                                          *q, *p)] + [report.impact_count])
        return rows

    compiled = steps()
    assert compiled == _python_march(steps)
    assert compiled[-1][-1] > 100


def test_a_flight_from_an_impact_starts_at_zero_gap():
    """After an impact the ice starts where the modes' sum puts the contact point, which may
    lie a rounding away from the impact's x: the flight's gap starts at 0, not below it, so
    its search finds no root at its start (a flight of zero length and an event for nothing,
    after 1 impact in 6 of Figure 2's scene with a second mode before)."""
    scene = Scene(**MARCH_SCENES["two modes"][0])
    sim = Simulator(scene)
    sim.advance(10.0)
    solver = sim.solver
    q, p = solver.modal_now(0.1)  # (the modal state the next flight starts from)
    x = solver.context.modes.contact(q, p)[0]
    off = math.nextafter(x, math.inf)  # (the impact's x, a rounding away)
    seg = solver._new_flight(sim.t, off, 0.1, off, 0.2, scene.flow_u, 0.0)
    assert seg.z0 == seg.x0 == x and seg.gap0 == 0.0
    ends = []
    original = ModalSolver.at_event

    def at_event(self, tau):
        if self.seg.phase.value == "flight":
            ends.append(tau)
        original(self, tau)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(ModalSolver, "at_event", at_event)
        mp.setattr(ModalSolver, "_bounce_march", lambda self: None)
        result = run(scene, 50.0)
    assert len(result.impacts) > 2000 and len(ends) >= len(result.impacts)
    assert min(ends) > 0.0


@compiled_only
def test_a_root_found_from_the_anchor_a_step_before_keeps_its_modal_state():
    """A flight whose root the search found in its first stretch (its frontier still at the
    anchor) during an earlier step, then a plastic impact there: the march takes the modal state
    at the root, not the anchor's (the search's state rows stay at the root), so the riding that
    follows is the Python march's to the bit. (A plausible-scene draw, seed 2024.)"""
    scene = Scene(ice_M=528.8046370450331, ice_A=3.3614626491550945, ice_Cd=0.7544288745605725,
                  flow_u=1.9692674667599208, impact_e=0.0, drag_model=1,
                  ice_v0=2.4293179404524725, ice_z0=-0.052692839874187825, structure_model=3,
                  structure_modes=2, structure_mode1_f=0.8879309113095919,
                  structure_mode1_zeta=0.08094927919360916, structure_mode1_m=4395.108529820917,
                  structure_mode2_f=9.180695071071415, structure_mode2_zeta=0.08094570165289221,
                  structure_mode2_m=24851.78559950968, structure_mode2_phi=0.19364473340823718)
    loads = (-6.776691344258618, -1444.2351424240474)

    def steps():
        sim, rows = Simulator(scene), []
        for _ in range(50):
            report = sim.advance(0.01, loads=loads)
            rows.append([float(value).hex() for value in (
                report.x, report.v, report.impulse, report.mode1_q, report.mode1_v,
                report.mode2_q, report.mode2_v)] + [report.sticking])
        return rows

    compiled = steps()
    assert compiled == _python_march(steps)
    assert compiled[5][-1]  # (riding after the plastic impact at 0.0217 s)


FIGURE2_TWO_MODES = dict(structure_model=3, structure_modes=2, structure_mode2_f=11.0,
                         structure_mode2_zeta=0.02, structure_mode2_phi=0.6)


def test_a_long_riding_phase_keeps_a_few_steps_and_the_same_floats():
    """Figure 2 with an 11 Hz second mode rides from about 54 s on. Stepped 1 s at a time to
    400 s (as the FMU steps), the phase drops the steps wholly before the times asked: it holds
    a few dozen of its thousands, and its states are those of a twin that keeps them all, to
    the bit; an earlier time asked makes them again from the anchor, the same floats."""
    sim = Simulator(Scene(**FIGURE2_TWO_MODES))
    for _ in range(400):
        sim.advance(1.0)
    ride = sim.solver.seg
    assert isinstance(ride, ModalRide)
    made = ride._dropped + int(ride._counts[0])
    assert made > 5000 and len(ride._steps) <= 64
    tau = sim.solver.tau
    twin = ModalRide(sim.solver.context, ride.t0, ride.q0, ride.p0, ride.u, ride.start)
    assert twin.state(tau) == ride.state(tau)
    assert len(twin._steps) >= made  # (the twin asked once: it kept every step)
    early = 0.25 * tau
    assert ride.state(early) == twin.state(early)  # (made again from the anchor)
    assert ride._dropped == 0 and ride.state(tau) == twin.state(tau)


def test_run_keeps_the_steps_of_a_chunk_of_samples_not_of_the_whole_riding_phase():
    """run() samples a segment of steps SAMPLE_CHUNK samples at a time, so a riding phase holds
    the steps of a chunk or two: the arrays are as large for 800 s as for 400 s (riding from
    54 s on, one step per 57 ms: 6,100 and 13,100 steps)."""
    largest = {}
    grow = ModalRide._grow
    for t_end in (400.0, 800.0):
        sizes = [0]

        def recorded(self, sizes=sizes):
            grow(self)
            sizes.append(len(self._steps))

        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(ModalRide, "_grow", recorded)
            result = run(Scene(**FIGURE2_TWO_MODES), t_end)
        assert result.sticking.sum() > 0.8 * t_end / 0.01
        largest[t_end] = max(sizes)
    assert largest[800.0] == largest[400.0] <= 2048
