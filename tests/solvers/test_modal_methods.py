"""Methods 2 (fixed-step) and 3 (ODE) with the modal structure (structure.model = 3), against
method 1 (ModalSolver), the SDOF runs of the same method, a restored snapshot and held loads."""

from __future__ import annotations

import math

import numpy as np
import pytest

from iceimpact.scene import Scene
from iceimpact.simulator import Simulator, run

#: mode 1 is the default SDOF structure (m 1600 kg, k 1e6 N/m, c 200 kg/s); mode 2 at 11 Hz
F1 = math.sqrt(1e6 / 1600.0) / (2.0 * math.pi)
ZETA1 = 200.0 / (2.0 * math.sqrt(1e6 * 1600.0))
MODES = dict(structure_model=3, structure_modes=2, structure_mode1_f=F1,
             structure_mode1_zeta=ZETA1, structure_mode1_m=1600.0, structure_mode1_phi=1.0,
             structure_mode2_f=11.0, structure_mode2_zeta=0.02, structure_mode2_m=1600.0,
             structure_mode2_phi=0.6)
#: quadratic drag with bounces; linear drag with e = 0, where the ice rides on the structure
QUADRATIC = dict(drag_model=2, flow_u=0.3, ice_M=1200.0, impact_e=0.7)
RIDING = dict(drag_model=1, flow_u=0.3, ice_M=1200.0, impact_e=0.0)
#: spans before any Zeno sequence method 3 closes earlier than method 1 (its position noise)
SPANS = {"quadratic": (QUADRATIC, 2.4), "riding": (RIDING, 3.0)}


def _scene(base: dict, method: int, **extra) -> Scene:
    return Scene(**{**base, **MODES, "solver_method": method, **extra})


@pytest.fixture(scope="module")
def exact_runs():
    return {name: run(_scene(base, 1), t_end) for name, (base, t_end) in SPANS.items()}


@pytest.mark.parametrize("name", SPANS)
def test_ode_matches_the_exact_impacts(name, exact_runs):
    base, t_end = SPANS[name]
    exact = exact_runs[name]
    ode = run(_scene(base, 3, solver_rtol=1e-10), t_end)
    t1, t3 = np.asarray(exact.impacts["t"]), np.asarray(ode.impacts["t"])
    assert len(t1) >= 3 and len(t3) == len(t1)
    assert np.max(np.abs(t3 - t1)) < 1e-6
    assert np.max(np.abs(np.asarray(ode.x) - np.asarray(exact.x))) < 1e-9
    assert np.array_equal(np.asarray(ode.sticking), np.asarray(exact.sticking))


@pytest.mark.parametrize("name", SPANS)
def test_fixed_step_converges_to_the_exact_run(name, exact_runs):
    base, t_end = SPANS[name]
    x1 = np.asarray(exact_runs[name].x)
    t1 = np.asarray(exact_runs[name].impacts["t"])
    errors, first_impact = [], []
    for dt in (1e-3, 1e-4, 1e-5):
        result = run(_scene(base, 2, solver_dt=dt), t_end)
        errors.append(np.max(np.abs(np.asarray(result.x) - x1)))
        first_impact.append(abs(result.impacts["t"][0] - t1[0]))
    # first order: each tenth of dt takes the displacement's error down at least 3-fold
    assert errors[1] < errors[0] / 3.0 and errors[2] < errors[1] / 3.0
    # the first impact on the grid point after it (the quadratic drag's Euler error besides)
    assert first_impact[2] <= 2e-5 and first_impact[1] <= 2e-4


@pytest.mark.parametrize("method, extra", [(2, {"solver_dt": 1e-4}),
                                           (3, {"solver_rtol": 1e-10})])
@pytest.mark.parametrize("name", SPANS)
def test_a_mode_off_the_contact_point_is_the_sdof(name, method, extra):
    base, t_end = SPANS[name]
    sdof = run(Scene(**{**base, "solver_method": method, **extra}), t_end)
    modal = run(_scene(base, method, structure_mode2_phi=0.0, **extra), t_end)
    t_s, t_m = np.asarray(sdof.impacts["t"]), np.asarray(modal.impacts["t"])
    assert len(t_s) == len(t_m) and len(t_s) >= 1
    # method 2: the same closed forms; method 3: the same ODE, its error control on more states
    tol_t, tol_x = (1e-12, 1e-15) if method == 2 else (1e-7, 1e-10)
    assert np.max(np.abs(t_s - t_m)) <= tol_t
    assert np.max(np.abs(np.asarray(sdof.x) - np.asarray(modal.x))) <= tol_x


def _march(sim: Simulator, steps: int, h: float, loads=None) -> list[tuple]:
    out = []
    for _ in range(steps):
        r = sim.advance(h, loads=loads)
        out.append((r.t, r.x, r.v, r.z, r.w, r.impact_count, r.sticking, r.mode1_q, r.mode2_v))
    return out


@pytest.mark.parametrize("method, extra", [(2, {"solver_dt": 1e-4}),
                                           (3, {"solver_rtol": 1e-8})])
@pytest.mark.parametrize("name", SPANS)
def test_restore_mid_run_continues_identically(name, method, extra):
    base, _ = SPANS[name]
    scene = _scene(base, method, **extra)
    sim = Simulator(scene)
    _march(sim, 70, 0.01, loads=(50.0, -20.0))  # inside the first bounces (t = 0.53 s on)
    saved = sim.save()
    ahead = _march(sim, 80, 0.01, loads=(50.0, -20.0))
    other = Simulator(scene)
    other.restore(saved)
    assert _march(other, 80, 0.01, loads=(50.0, -20.0)) == ahead


@pytest.mark.parametrize("method, extra, tol", [(2, {"solver_dt": 1e-4}, 1e-15),
                                                (3, {"solver_rtol": 1e-10}, 1e-11)])
def test_held_loads_move_the_modes_as_method_1(method, extra, tol):
    """Far from the ice, a load L on mode 1 offsets it by L / k_1 (a step response about it);
    methods 2 and 3 follow method 1 step by step, and the offset is the closed form's."""
    far = dict(ice_z0=-1.0, ice_v0=0.0, flow_u=0.0)
    load, h, steps = 500.0, 0.01, 200
    k1 = 1600.0 * (2.0 * math.pi * F1) ** 2
    runs = {}
    for m, kw in ((1, {}), (method, extra)):
        sim = Simulator(_scene(RIDING, m, **far, **kw))
        runs[m] = np.array([(r[1], r[7]) for r in _march(sim, steps, h, loads=(load, 0.0))])
    assert np.max(np.abs(runs[method] - runs[1])) <= tol
    # the step response of mode 1 from rest: q = L / k (1 - e^(-sigma t) (cos + sigma / w sin))
    t = h * np.arange(1, steps + 1)
    sigma = ZETA1 * 2.0 * math.pi * F1
    wd = 2.0 * math.pi * F1 * math.sqrt(1.0 - ZETA1 ** 2)
    q = load / k1 * (1.0 - np.exp(-sigma * t) * (np.cos(wd * t) + sigma / wd * np.sin(wd * t)))
    assert np.max(np.abs(runs[method][:, 1] - q)) <= 1e-12
    assert np.max(np.abs(runs[method][:, 0] - q)) <= 1e-12  # mode 2 rests: x = q_1


@pytest.mark.parametrize("method, extra", [(2, {"solver_dt": 1e-4}),
                                           (3, {"solver_rtol": 1e-10})])
def test_loads_change_the_contact_motion_as_method_1(method, extra):
    base, _ = SPANS["quadratic"]
    loads = (-300.0, 100.0)
    runs = {}
    for m, kw in ((1, {}), (method, extra)):
        sim = Simulator(_scene(base, m, **kw))
        runs[m] = np.array([r[:5] for r in _march(sim, 100, 0.01, loads=loads)])
    free = np.array([r[:5] for r in _march(Simulator(_scene(base, 1)), 100, 0.01)])
    moved = np.max(np.abs(runs[1][:, 1] - free[:, 1]))
    assert moved > 1e-5  # the loads change the motion ...
    # ... and the method follows method 1 (method 2 to its grid's error)
    assert np.max(np.abs(runs[method][:, 1] - runs[1][:, 1])) < (0.05 if method == 2
                                                                   else 1e-6) * moved
