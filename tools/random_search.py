"""Random search for faults at the extremes: hypothesis scenes, each run with a time limit.

    python tools/random_search.py --method 1 --seed 23 --examples 2000
    python tools/random_search.py --method 1 --seed 5 --examples 3000 --scales --flows
    python tools/random_search.py --method 2 --seed 112 --examples 3000 --far

Each random scene (the strategy of tools/scene_strategies.py, with the chosen solver method;
method 2 uses the gap-sign test unless --detection 1) runs for 3 s (method 3: 1 s) at a random
communication step of 1 ms to 10 s, with a limit of 30 s of CPU time (the machine may be
shared: wall time would flag scenes slowed by other work).

``--scales`` draws the scales out to what validation accepts (omega_n up to the method's limit,
masses from 1e-6 to 1e9 kg, flows up to the drag-rate limit, steps down to 0.1 ms); ``--flows``
drives the flow input with a random sequence: constant, reversing at every step, random signs,
zero, reversed one step in four. ``--far`` draws from a wider box than validation's limits
(stiffness down to 1e-200 N/m, fluid.rho 1e-200 to 1e30 kg/m^3, drag.v_lin up to 1e200 m/s,
masses 1e-6 to 1e9 kg, impact.e 1e-12 to 1; the initial displacements and speeds of both
bodies near the contact scale or log-uniform from 1e-300 up to validation's bounds, either sign,
the ice in contact or up to 1e308 m upstream) and runs each scene FAR_STEPS = 300 communication
steps of 0.01 to 1 s under a flow constant, zero, reversing at every step or random in sign and
size (``--steps``: another number of steps, the same scenes); the scenes validation refuses up
front are counted by the rule that refused them; method 3
integrates with ``solver.max_evaluations`` = FAR_EVALUATIONS per step (``--max-evaluations``), so
that a scene whose integration needs more is refused at a step naming that limit. Scenes
the model refuses (ParameterError, at the start or at a step, or a SolverError naming the
limit, such as method 2's unstable Euler step) are counted and skipped. Every numpy warning is
an error (a FAIL naming where it was raised): an invalid value computed on the way is a fault
even where it is discarded.

Printed: every scene that stalls (TIMEOUT: out of CPU time with its work beyond what its
impacts or its rate rule allow, see :func:`busy_with_impacts` and :func:`busy_integrating`),
produces a non-finite output, a negative gap beyond
its method's tolerance, a tensile (negative) contact impulse beyond rounding, or energy created
while the flow is zero (FAIL), or is slow (SLOW); then the counts. docs/robustness.md reports
the searches.

Each flagged scene is followed by a line ``REPLAY {...}``: a JSON object with everything the run
used (every scene field at full precision, the step, the flow sequence, its sign list and the
time limit). Re-run that one case with

    python tools/random_search.py --replay '{"scene": {...}, "h": 0.0001, ...}'

or from Python with :func:`replay` (the tests pin faults this way): the same steps, flows and
checks as the search.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import signal
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, assume, given, seed, settings
from hypothesis import strategies as st

from iceimpact import ParameterError, Scene, Simulator, SolverError
from iceimpact.limits import (
    DRAG_RATE_MAX,
    ODE_EXPLICIT_RATE_MAX,
    OMEGA_MAX_EXACT,
    OMEGA_MAX_ODE,
    TAYLOR_RATE_MAX,
    integrated_rate,
)
from iceimpact.solvers.base import State
from iceimpact.solvers.contact_rules import ZENO_BUDGET, chatter_time
from iceimpact.solvers.ode import ATOL_SCALE, ODE_METHODS, PARTING_NOISE, STABLE_STEP
from scene_strategies import scenes

TIME_LIMIT = 30.0  # s of CPU time per scene (not wall time: the machine may be shared)
# m; method 3: 10 atol; method 2 reports its grid penetration instead
GAP_TOLERANCE = {1: 1e-12, 2: math.inf, 3: 1e-10}
# relative to the scene's momentum scale: rounding (methods 1, 2), integration error (3)
IMPULSE_TOLERANCE = {1: 1e-9, 2: 1e-9, 3: 1e-5}
# relative growth of the energy at u = 0 (docs/robustness.md, the extremes matrix); method 3
# is held to its integration's bound instead, ode_energy_bound
ENERGY_TOLERANCE = {1: 1e-9, 2: 1e-9, 3: 1e-5}
#: right-hand-side evaluations per step of method 3's explicit integrators (at least: rejected
#: steps and the dense output's extra stages count too, so nfev / STAGES over-counts the steps)
STAGES = {"RK45": 6, "DOP853": 12}
#: the error norm of scipy's step control is an RMS over the state's (up to 5) components, so
#: one component's error reaches sqrt(5) < 3 times its tolerance atol + rtol |y|
NORM_FACTOR = 3.0
#: rounding of the states: a few ulps of the positions and speeds they add up
STATE_ULPS = 8.0 * 2.0 ** -52
#: s of CPU per impact (with the search's checks) within which a run out of CPU time is busy
#: with its impacts, not stalled: 3x the costliest measured (an elastic chatter's impacts cost
#: 20-40 us; a plastic stick-part cycle's 0.33 ms, each impact with a separation and a flight
#: of half a period; docs/robustness.md, "Many real impacts at a stiff structure")
IMPACT_WORK = 1e-3
#: method 3's evaluations per unit rate and simulated second, per communication step and in
#: all, within which a run out of CPU time is busy integrating (:func:`busy_integrating`; the
#: bound of fix 30's test, and 100 for each restart at a flow change)
ODE_WORK, ODE_RESTART_WORK, ODE_WORK_FLOOR = 4.0, 100, 2000
#: method 3's evaluations per rad/s of omega_n and simulated second within which a run is busy
#: integrating the structure's oscillation (DOP853: 23 measured on an undamped 1087 rad/s
#: structure, 10-20 steps a period; docs/robustness.md, "The far-scale search")
ODE_OMEGA_WORK = 40.0
FLOWS = ("constant", "reversing", "random signs", "zero", "reversed 1 in 4")
#: the flow sequences of the far-scale search (--far): "random" draws each step's sign and size
FAR_FLOWS = ("constant", "zero", "reversing", "random")
#: communication steps of the far-scale search: so many, of 0.01 to 1 s
FAR_STEPS = 300
#: method 3's evaluation budget per step in the far-scale search (solver.max_evaluations), the
#: host's bound on a 300-step run: at ~5 us an evaluation, 300 steps of 5,000 (and as much again
#: integrated ahead and discarded at a change of the flow) are ~15 s of CPU
FAR_EVALUATIONS = 5_000
OMEGA_MAX = {1: OMEGA_MAX_EXACT, 2: 1e12, 3: OMEGA_MAX_ODE}
#: the drag-rate limit of each method's validation (method 3: its explicit integrators, the
#: default DOP853)
RATE_MAX = {1: DRAG_RATE_MAX, 2: DRAG_RATE_MAX, 3: ODE_EXPLICIT_RATE_MAX}


class _Stalled(Exception):
    pass


def _alarm(signum, frame):
    raise _Stalled


def _progress(sim: Simulator) -> tuple[float, int, int]:
    """(simulated time, impacts, right-hand-side evaluations) reached so far, within a step
    too: the start of the exact method's current segment, the end of method 3's last
    integration call and its evaluations until then (a step that runs out of time is rolled
    back, so the simulator's own time and counts stay at the last step's end)."""
    solver = sim.solver
    seg = getattr(solver, "seg", None)
    t = max(sim.t, getattr(seg, "t0", -math.inf), getattr(solver, "chunk_hi", -math.inf))
    return t, solver.impact_count, getattr(solver, "nfev", 0)


class _HalfwayAlarm:
    """The CPU-time limit in two halves: at the first alarm, note the CPU time and the
    progress (:func:`_progress`: the checkpoint :func:`busy_with_impacts` judges the second
    half from); at the second, note the progress again and stop the run (_Stalled)."""

    def __init__(self, sim: Simulator):
        self.sim = sim
        self.checkpoint: tuple[float, float, int, int] | None = None
        self.end: tuple[float, float, int, int] | None = None

    def __call__(self, signum, frame):
        mark = (time.process_time(), *_progress(self.sim))
        if self.checkpoint is None:
            self.checkpoint = mark
            return
        self.end = mark
        raise _Stalled


@st.composite
def scale_scenes(draw, method: int):
    """Valid scenes out to the scales validation accepts for ``method``."""
    m = 10 ** draw(st.floats(-6.0, 9.0))
    omega_n = 10 ** draw(st.floats(-3.0, math.log10(OMEGA_MAX[method])))
    zeta = draw(st.one_of(st.just(0.0), st.just(1.0), st.floats(0.0, 50.0)))
    k = m * omega_n ** 2
    M = m * 10 ** draw(st.floats(-4.0, 4.0))
    A = 10 ** draw(st.floats(-3.0, 3.0))
    Cd = draw(st.one_of(st.just(0.0), st.floats(0.0, 2.0)))
    drag = draw(st.sampled_from([1, 2]))
    B = 0.5 * 999.0 * Cd * A
    u_max = 100.0 if B == 0.0 else min(1e4, 0.4 * RATE_MAX[method] * M / (2.0 * B))
    if method == 1 and B > 0.0:  # and the sticking phase's drag rate 2 B u / (m + M)
        u_max = min(u_max, 0.4 * TAYLOR_RATE_MAX * (m + M) / (2.0 * B))
    x0 = draw(st.one_of(st.just(0.0), st.floats(-1.0, 1.0)))
    v0 = draw(st.floats(-1.0, 1.0))
    try:
        return _scene(draw, m, k, zeta, M, A, Cd, drag, u_max, x0, v0, method)
    except ParameterError:  # a combination validation refuses: not a scene to run
        assume(False)


def _scene(draw, m, k, zeta, M, A, Cd, drag, u_max, x0, v0, method):
    return Scene(
        structure_m=m, structure_k=k, structure_c=2.0 * zeta * math.sqrt(k * m),
        structure_x0=x0, structure_v0=v0, ice_M=M, ice_A=A, ice_Cd=Cd,
        ice_z0=x0 - draw(st.one_of(st.just(0.0), st.floats(0.0, 0.1))),
        ice_v0=draw(st.one_of(st.just(v0), st.just(0.0), st.floats(-u_max / 2, u_max / 2))),
        impact_e=draw(st.one_of(st.just(0.0), st.just(1.0), st.floats(0.0, 1.0))),
        drag_model=drag, drag_v_lin=10 ** draw(st.floats(-3.0, 1.0)),
        flow_u=draw(st.one_of(st.just(0.0), st.floats(-u_max, u_max))),
        solver_method=method)


#: the far box's initial states: magnitudes log-uniform from FAR_MIN up to validation's bound
#: (the largest finite double for a position of the ice, whose energy is all kinetic)
FAR_MIN, FAR_MAX = 1e-300, sys.float_info.max


def energy_bound(stiffness: float) -> float:
    """The largest |q| whose energy stiffness q^2 / 2 validation accepts (finite): a position
    of the structure (stiffness k, N/m) or a speed (a mass, kg); just inside it."""
    return min(FAR_MAX, 0.999 * math.sqrt(2.0) * math.sqrt(FAR_MAX) / math.sqrt(stiffness))


def far_values(bound: float, signed: bool = True) -> st.SearchStrategy[float]:
    """Magnitudes log-uniform from FAR_MIN to ``bound`` over their whole range, either sign."""
    top = math.log10(bound) - 1e-9  # 10 ** top rounds below the bound, never to inf
    magnitude = st.floats(math.log10(FAR_MIN), top).map(lambda p: min(10 ** p, bound))
    if not signed:
        return magnitude
    return st.tuples(st.booleans(), magnitude).map(lambda t: t[1] if t[0] else -t[1])


@st.composite
def far_scenes(draw, method: int):
    """Scenes from the far box (docs/robustness.md, "The far-scale search"): stiffness from
    1e-200 N/m to the method's omega_n limit, fluid density 1e-200 to 1e30 kg/m^3, drag.v_lin
    up to 1e200 m/s, masses 1e-6 to 1e9 kg, restitution 1e-12 to 1 (and 0, 1 exactly); flows
    up to 1e4 m/s, or within 0.4 of the drag-rate limits. The initial states: structure.x0 0,
    in [-1, 1] m or anywhere a finite strain energy allows, structure.v0 in [-1, 1] m/s or up
    to a finite kinetic energy, the ice in contact (ice.z0 = structure.x0), up to 0.1 m or up
    to 1e308 m upstream, ice.v0 the structure's, 0, within half the flow bound or up to a
    finite kinetic energy (:func:`far_values`: log-uniform magnitudes from 1e-300, either
    sign). Scenes validation refuses up front are counted by the caller (:class:`_Refusals`)
    and not run."""
    m = 10 ** draw(st.floats(-6.0, 9.0))
    M = 10 ** draw(st.floats(-6.0, 9.0))
    k_max = math.log10(m) + 2.0 * math.log10(OMEGA_MAX[method])
    k = 10 ** draw(st.one_of(st.floats(-200.0, k_max),
                             st.floats(math.log10(m) - 6.0, k_max)))
    zeta = draw(st.one_of(st.just(0.0), st.just(1.0), st.floats(0.0, 50.0)))
    rho = 10 ** draw(st.one_of(st.floats(-200.0, 30.0), st.floats(-3.0, 4.0)))
    A = 10 ** draw(st.floats(-3.0, 3.0))
    Cd = draw(st.one_of(st.just(0.0), st.floats(0.0, 2.0)))
    drag = draw(st.sampled_from([1, 2]))
    v_lin = 10 ** draw(st.one_of(st.floats(-3.0, 200.0), st.floats(-3.0, 1.0)))
    B = 0.5 * rho * Cd * A
    u_free = 10 ** draw(st.floats(-3.0, 4.0))
    u_max = u_free if B == 0.0 else min(u_free, 0.4 * RATE_MAX[method] * M / (2.0 * B))
    if method == 1 and B > 0.0:
        u_max = min(u_max, 0.4 * TAYLOR_RATE_MAX * (m + M) / (2.0 * B))
    u_max = draw(st.sampled_from([u_max, u_free]))
    # the initial states: near the contact scale, or anywhere up to validation's bounds
    x0 = draw(st.one_of(st.just(0.0), st.floats(-1.0, 1.0),
                        far_values(energy_bound(k))))
    v0 = draw(st.one_of(st.floats(-1.0, 1.0), far_values(energy_bound(m))))
    gap = draw(st.one_of(st.just(0.0), st.floats(0.0, 0.1), far_values(FAR_MAX, signed=False)))
    w0 = draw(st.one_of(st.just(v0), st.just(0.0), st.floats(-u_max / 2, u_max / 2),
                        far_values(energy_bound(M))))
    e = draw(st.one_of(st.just(0.0), st.just(1.0),
                       st.floats(-12.0, 0.0).map(lambda p: 10 ** p)))
    try:
        return Scene(
            structure_m=m, structure_k=k, structure_c=2.0 * zeta * math.sqrt(k * m),
            structure_x0=x0, structure_v0=v0, ice_M=M, ice_A=A, ice_Cd=Cd,
            ice_z0=max(x0 - gap, -FAR_MAX), ice_v0=w0,
            fluid_rho=rho, impact_e=e, drag_model=drag, drag_v_lin=v_lin,
            flow_u=draw(st.one_of(st.just(0.0), st.floats(-u_max, u_max))),
            solver_method=method)
    except ParameterError as exc:  # refused up front: counted, not run
        _REFUSALS.note(exc)
        assume(False)


class _Refusals:
    """Scenes validation refused up front, by the name of the parameter or rule refused."""

    def __init__(self):
        self.by_name: dict[str, int] = {}

    def note(self, exc: ParameterError) -> None:
        name = getattr(exc, "name", None) or str(exc).split(" = ")[0]
        self.by_name[name] = self.by_name.get(name, 0) + 1

    def total(self) -> int:
        return sum(self.by_name.values())


_REFUSALS = _Refusals()


def flow_at(kind: str, i: int, u: float, signs: list[bool],
            sizes: list[float] | None = None) -> float:
    """Flow speed of communication step i under a sequence ``kind`` around speed u ("random":
    the sign from ``signs`` and the size from ``sizes``, fractions of u, each cycled)."""
    if kind == "random":
        size = sizes[i % len(sizes)] if sizes else 1.0
        return (u if signs[i % len(signs)] else -u) * size
    if kind == "reversing":
        return u if i % 2 == 0 else -u
    if kind == "random signs":
        return u if signs[i % len(signs)] else -u
    if kind == "zero":
        return 0.0
    if kind == "reversed 1 in 4":
        return -u if i % 4 == 3 else u
    return u


def energy(scene: Scene, s) -> float:
    """Mechanical energy 1/2 m v^2 + 1/2 k x^2 + 1/2 M w^2, J (products, not powers: a float's
    ** raises OverflowError where x^2 alone overflows, k x^2 need not)."""
    return 0.5 * (scene.structure_m * s.v * s.v + scene.structure_k * s.x * s.x
                  + scene.ice_M * s.w * s.w)


def grid_energy(scene: Scene, solver, e_now: float, s) -> tuple[float, State]:
    """Method 2's reference for the next step's energy at u = 0 (J), with its state: the larger
    of the energy at the solver's last grid point (after an impact there) and ``e_now``, that
    of the state ``s`` at the communication point. Between grid points ``s`` is a partial Euler
    step from the grid point (eq. 36 over h < dt), whose |w - u| shrinks over the step but
    passes through 0 where the step overshoots the flow speed (1 < (B/M) dt |w - u| <= 2): a
    communication point there reports less energy than its grid point, and the next one more,
    without energy created. On the grid the energy never grows, and a communication point's
    never exceeds its grid point's (docs/robustness.md, "Method 2's partial Euler step")."""
    if solver.pinned:
        return e_now, s
    grid = State(s.t, *solver.grid)
    e_grid = energy(scene, grid)
    return (e_grid, grid) if e_grid > e_now else (e_now, s)


def ode_energy_bound(scene: Scene, e: float, nfev: int) -> float:
    """Largest energy growth (J) method 3's step control allows over ``nfev`` right-hand-side
    evaluations from energy e (J) at u = 0 (docs/accuracy.md, "Method 3's energy error").
    Each accepted step keeps each state's local error within NORM_FACTOR (atol + rtol |y|),
    atol = ATOL_SCALE rtol; E = 1/2 (m v^2 + k x^2 + M w^2) then moves by at most
    NORM_FACTOR (2 rtol E + atol (k |x| + m |v| + M |w|)) <= NORM_FACTOR (2 rtol E + atol
    sqrt(2 E) (sqrt(k) + sqrt(m) + sqrt(M))) a step (k |x| = sqrt(k) sqrt(k x^2)), and an
    exactly elastic impact at the located state moves it by nothing; over N <= nfev / STAGES
    steps, N times that. With nothing dissipating the error only accumulates: it grows with the
    steps (20 a period: ~23 evaluations per omega_n and simulated second), not with time."""
    rtol = scene.solver_rtol
    atol = ATOL_SCALE * rtol
    steps = nfev / STAGES.get(ODE_METHODS[scene.solver_ode_method], 1)
    roots = (math.sqrt(scene.structure_k) + math.sqrt(scene.structure_m)
             + math.sqrt(scene.ice_M))
    return NORM_FACTOR * steps * (2.0 * rtol * e + atol * math.sqrt(2.0 * e) * roots)


def energy_floor(scene: Scene, s, u: float, atol: float) -> float:
    """Absolute uncertainty of :func:`energy` (J) from the uncertainty of the states it is
    computed from: each position carries ``atol`` (method 3's absolute integration tolerance,
    0 for the closed forms) plus a few ulps of the positions it is made of, each speed the same
    of the speeds (the structure's includes omega_n times its position scale). With
    dE = m |v| dv + k |x| dx + M |w| dw + (m dv^2 + k dx^2 + M dw^2) / 2, a growth below this
    is rounding: it matters when the energy itself is tiny (1e-138 J was flagged relative to
    an initial energy that small)."""
    m, k, M = scene.structure_m, scene.structure_k, scene.ice_M
    dx = atol + STATE_ULPS * (abs(s.x) + abs(s.z))
    dv = atol + STATE_ULPS * (abs(s.v) + abs(s.w) + abs(u)
                              + math.sqrt(k / m) * (abs(s.x) + abs(s.z)))
    return (m * abs(s.v) * dv + k * abs(s.x) * dx + M * abs(s.w) * dv
            + 0.5 * (m * dv * dv + k * dx * dx + M * dv * dv))


@dataclasses.dataclass
class Outcome:
    """What one case gave: the fault's text (None: sound), whether a step was refused, the CPU
    time (s), the simulated time reached (s), the most negative gap seen (m), the impacts
    resolved, and whether a run out of CPU time was busy with its impacts or its integration
    (:func:`busy_with_impacts`, :func:`busy_integrating`; printed BUSY, not a fault)."""
    fault: str | None
    refused: bool
    cpu: float
    t: float
    min_gap: float
    impacts: int = 0
    busy: bool = False
    refusal: str | None = None  # the message of a refused step


def busy_with_impacts(scene: Scene, t: float, impacts: int, cpu: float,
                      late_impacts: int, late_cpu: float) -> bool:
    """A run out of CPU time is busy with its impacts, not stalled, when its work went into
    impacts at the rate the contact rules allow: ``impacts`` by simulated time t at most one
    per chatter time (the chatter closure ends the bouncing of bodies pressed together once a
    bounce would be shorter than solver.chatter_fraction of the structure's period,
    docs/robustness.md "Many real impacts at a stiff structure"), and at most IMPACT_WORK s of
    CPU each, over the whole run (``cpu``) and over its second half (``late_impacts`` in
    ``late_cpu``: a run stalled after many quick impacts is not busy). With e < 1 method 1
    follows each Zeno sequence bounce by bounce below the chatter time, ZENO_BUDGET bounces at
    most (:mod:`iceimpact.solvers.contact_rules`), so each chatter time may hold that many
    more. Such a run is bounded:
    its CPU per simulated second is at most IMPACT_WORK / chatter_time; it is slow only because
    it resolves up to ~16 omega_n real impacts per simulated second."""
    if late_impacts <= 0 or t <= 0.0:
        return False
    cap = t / chatter_time(scene.omega_n, scene.solver_chatter_fraction) + 1.0
    if scene.impact_e < 1.0 and scene.solver_method == 1:
        # method 1 follows a Zeno sequence past the chatter time, ZENO_BUDGET bounces at most
        # (contact_rules): each chatter time may start one
        cap *= 1.0 + ZENO_BUDGET
    return (impacts <= cap and cpu <= IMPACT_WORK * impacts
            and late_cpu <= IMPACT_WORK * late_impacts)


def busy_integrating(scene: Scene, u: float, t: float, nfev: int, steps: int) -> bool:
    """A method-3 run (its explicit integrator, the search's DOP853) out of CPU time is busy
    integrating, not stalled, when its right-hand-side evaluations up to simulated time t keep
    within what its rate rule allows: ODE_WORK evaluations per unit of the fastest rate it
    integrates (``integrated_rate`` at the flow speed u: DOP853 makes 15 evaluations per step
    of at most STABLE_STEP / rate = 1 / (5 rate) s, 3 rate per simulated second, plus its
    restarts at impacts), or ODE_OMEGA_WORK per rad/s of omega_n where that is more (its steps
    per period of the structure), ODE_RESTART_WORK per communication step (a flow change
    restarts the integration) and ODE_WORK_FLOOR. Such a run costs up to ~10 s of CPU per
    simulated second at the rate limit, 3e5 1/s (docs/robustness.md, fix 30, and Open), and
    ~1 s at omega_n's, 1e4 rad/s (300 steps of 1 s: ~300 s)."""
    if (scene.solver_method != 3 or ODE_METHODS[scene.solver_ode_method] not in STABLE_STEP
            or t <= 0.0):
        return False
    rate = integrated_rate(scene, u)
    # the steps are the shorter of the rate's stable step and the accuracy's per period
    return nfev <= (max(ODE_WORK * rate, ODE_OMEGA_WORK * scene.omega_n) * t
                    + ODE_RESTART_WORK * steps + ODE_WORK_FLOOR)


def run_case(scene: Scene, h: float, flow: str, signs: list[bool],
             time_limit: float = TIME_LIMIT, sizes: list[float] | None = None,
             steps: int | None = None) -> Outcome:
    """Run one scene of the search (its method is ``scene.solver_method``) at communication step
    h under the flow sequence ``flow`` (with ``signs`` for "random signs" and "random",
    ``sizes`` for "random"), checking every step: finite outputs, gap, contact impulse, energy
    at u = 0, and no numpy warning (each is an error: an invalid value computed on the way).
    ``steps``: so many communication steps (the far-scale search), else the horizon of 3 s
    (method 3: 1 s; 50 ms below 1 ms steps). Stops at the first fault, at a refused step, or
    after ``time_limit`` s of CPU time (a TIMEOUT fault)."""
    with warnings.catch_warnings(), np.errstate(all="warn", under="ignore"):
        warnings.simplefilter("error")
        return _run_case(scene, h, flow, signs, time_limit, sizes, steps)


def _run_case(scene: Scene, h: float, flow: str, signs: list[bool], time_limit: float,
              sizes: list[float] | None, steps: int | None) -> Outcome:
    method = scene.solver_method
    sim = Simulator(scene)
    t_end = 3.0 if method != 3 else 1.0
    if h < 1e-3:
        t_end = min(t_end, 0.05)
    u0 = scene.flow_u if scene.flow_u != 0.0 or flow == "zero" else 0.1
    last = sim.solver.state
    e_last = energy(scene, last)
    atol = ATOL_SCALE * scene.solver_rtol if method == 3 else 0.0
    # method 3 takes a parting within its velocities' tolerance, PARTING_NOISE (rtol |v| + atol),
    # for integration noise and sticks the bodies with a plastic entry (contact_rules'
    # stick_slow_parting): a tensile impulse of up to mu PARTING_NOISE atol is its absolute
    # tolerance, as the gap's is (GAP_TOLERANCE); the relative part is within IMPULSE_TOLERANCE
    mu = scene.structure_m * scene.ice_M / (scene.structure_m + scene.ice_M)
    impulse_floor = mu * PARTING_NOISE * atol
    e_scale = max(e_last, 1e-300)
    e_least = e_most = e_last
    fault, refused, min_gap, busy = None, False, math.inf, False
    refusal = None
    reached = None  # (simulated time, impacts) where a run out of CPU time stood
    start = time.process_time()
    alarm = _HalfwayAlarm(sim)
    previous = signal.signal(signal.SIGPROF, alarm)
    signal.setitimer(signal.ITIMER_PROF, 0.5 * time_limit, 0.5 * time_limit)
    i = 0
    try:
        while (i < steps) if steps is not None else (sim.t < t_end - 1e-12):
            u = flow_at(flow, i, u0, signs, sizes)
            i += 1
            try:
                r = sim.advance(h if steps is not None else min(h, t_end - sim.t), u)
            except (ParameterError, SolverError) as exc:  # a refusal that names the limit
                refused, refusal = True, str(exc)
                break
            values = [r.x, r.v, r.z, r.w, r.gap, r.penetration, r.impulse, r.force, r.t_last]
            if not all(map(math.isfinite, values)):
                raise AssertionError(f"non-finite output {values}")
            s = sim.solver.state
            min_gap = min(min_gap, s.x - s.z)
            if s.x - s.z < -GAP_TOLERANCE[method]:
                raise AssertionError(f"gap {s.x - s.z} m at t = {r.t}")
            momentum = ((scene.structure_m + scene.ice_M) * (abs(s.v) + abs(s.w) + abs(u))
                        + scene.structure_k * abs(s.x) * h)
            if r.impulse < -IMPULSE_TOLERANCE[method] * momentum - impulse_floor - 1e-300:
                raise AssertionError(f"tensile contact impulse {r.impulse} N.s at "
                                     f"t = {r.t} (scale {momentum:.3g})")
            e_now = energy(scene, s)
            floor = energy_floor(scene, s, u, atol) + energy_floor(scene, last, u, atol)
            if method == 3:  # since the least energy so far, by every step integrated yet
                # (a chunk is integrated ahead of the steps it serves)
                e_least, e_most = min(e_least, e_last), max(e_most, e_now)
                if flow == "zero" and e_now > e_least + floor + ode_energy_bound(
                        scene, e_most, sim.solver.nfev):
                    raise AssertionError(f"energy created at u = 0: {e_least} -> {e_now} J "
                                         f"by t = {r.t}, beyond the integration's bound")
            elif flow == "zero" and e_now > (e_last + ENERGY_TOLERANCE[method] * e_scale
                                             + floor):
                raise AssertionError(f"energy created at u = 0: {e_last} -> {e_now} J "
                                     f"at t = {r.t}")
            e_last, last = e_now, s
            if method == 2:
                e_last, last = grid_energy(scene, sim.solver, e_now, s)
    except _Stalled:
        cpu, t_reached, impacts, nfev = alarm.end or (time.process_time(), *_progress(sim))
        half_cpu, _, half_impacts, _ = alarm.checkpoint or (start, 0.0, 0, 0)
        busy = (busy_with_impacts(scene, t_reached, impacts, cpu - start,
                                  impacts - half_impacts, cpu - half_cpu)
                or busy_integrating(scene, u0, t_reached, nfev, i))
        reached = (t_reached, impacts)
        if not busy:
            fault = f"TIMEOUT at t = {sim.t} s, h = {h} s, flow {flow}: {scene}"
    except Exception as exc:
        fault = f"FAIL {exc!r}{_where(exc)}, h = {h} s, flow {flow}: {scene}"
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0.0)
        signal.signal(signal.SIGPROF, previous)
    t_out, impacts_out = reached or (sim.t, sim.impact_count)
    return Outcome(fault, refused, time.process_time() - start, t_out, min_gap, impacts_out,
                   busy, refusal)


def _where(exc: Exception) -> str:
    """' at file:line' of the innermost frame of the package that raised ``exc`` (a numpy
    warning turned error is raised where it was computed)."""
    where = ""
    tb = exc.__traceback__
    while tb is not None:
        path = tb.tb_frame.f_code.co_filename
        if "iceimpact" in path:
            where = f" at {Path(path).name}:{tb.tb_lineno}"
        tb = tb.tb_next
    return where


def case_text(scene: Scene, h: float, flow: str, signs: list[bool],
              time_limit: float = TIME_LIMIT, sizes: list[float] | None = None,
              steps: int | None = None) -> str:
    """One case as JSON, every float at repr() precision (what :func:`replay` reads)."""
    case = {"scene": dataclasses.asdict(scene), "h": h, "flow": flow, "signs": list(signs),
            "time_limit": time_limit}
    if steps is not None:
        case.update(sizes=list(sizes or []), steps=steps)
    return json.dumps(case)


def replay(text: str) -> Outcome:
    """Re-run one case printed by the search (its ``REPLAY`` line's JSON, or the dict); a
    scene the validation refuses gives an outcome "REFUSED up front: <message>"."""
    case = json.loads(text) if isinstance(text, str) else text
    try:
        scene = Scene(**case["scene"])
    except ParameterError as exc:  # a scene the validation now refuses up front
        return Outcome(f"REFUSED up front: {exc}", True, 0.0, 0.0, math.inf)
    return run_case(scene, case["h"], case["flow"], case["signs"],
                    case.get("time_limit", TIME_LIMIT), case.get("sizes"), case.get("steps"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--method", type=int, choices=(1, 2, 3), default=1)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--examples", type=int, default=500)
    parser.add_argument("--detection", type=int, choices=(1, 2), default=2,
                        help="impact test of method 2: 1 = eq. 26 window, 2 = gap sign")
    parser.add_argument("--scales", action="store_true",
                        help="scales out to the validation limits")
    parser.add_argument("--flows", action="store_true", help="random flow sequences")
    parser.add_argument("--far", action="store_true",
                        help=f"the far box: {FAR_STEPS} steps of 0.01-1 s, stiffness down to "
                        "1e-200 N/m, fluid.rho 1e-200 to 1e30, drag.v_lin up to 1e200, initial "
                        "displacements and speeds up to validation's bounds, flows "
                        "constant, zero, reversing or random in sign and size")
    parser.add_argument("--steps", type=int, metavar="N", default=FAR_STEPS,
                        help=f"communication steps of each far-box scene (default {FAR_STEPS}): "
                        "fewer for a cheaper, shorter search of the same scenes")
    parser.add_argument("--max-evaluations", type=int, metavar="N",
                        help="method 3: solver.max_evaluations of every scene (default: the "
                        f"scene's; {FAR_EVALUATIONS} with --far)")
    parser.add_argument("--time-limit", type=float, default=TIME_LIMIT,
                        help="s of CPU time per scene before it counts as a TIMEOUT")
    parser.add_argument("--replay", metavar="JSON",
                        help="re-run one case printed on a REPLAY line, print its outcome")
    args = parser.parse_args()
    if args.replay is not None:
        outcome = replay(args.replay)
        busy = "BUSY: its work within the bounds of its rules"
        verdict = outcome.fault or (busy if outcome.busy else "sound")
        print(verdict, f"({outcome.impacts} impacts, refused at a step: {outcome.refused}, CPU "
              f"{outcome.cpu:.2f} s, t = {outcome.t} s, smallest gap {outcome.min_gap!r} m)")
        return
    found: list[str] = []
    count = refused = busy = 0
    strategy = (far_scenes(args.method) if args.far else scale_scenes(args.method)
                if args.scales else scenes())
    steps = [1e-4, 1e-3, 0.01, 0.37, 10.0] if args.scales else [1e-3, 0.01, 0.37, 10.0]
    step_strategy = (st.floats(-2.0, 0.0).map(lambda p: 10 ** p) if args.far
                     else st.sampled_from(steps))
    flows = (st.sampled_from(FAR_FLOWS) if args.far else st.sampled_from(FLOWS) if args.flows
             else st.just("constant"))
    n_steps = args.steps if args.far else None
    evaluations = args.max_evaluations or (FAR_EVALUATIONS if args.far else None)
    budget = ({"solver_max_evaluations": evaluations}
              if args.method == 3 and evaluations is not None else {})

    @seed(args.seed)
    @settings(max_examples=args.examples, deadline=None, database=None,
              suppress_health_check=list(HealthCheck))
    @given(scene=strategy, h=step_strategy, flow=flows,
           signs=st.lists(st.booleans(), min_size=1, max_size=16),
           sizes=st.lists(st.one_of(st.just(0.0), st.floats(-6.0, 0.0).map(lambda p: 10 ** p)),
                          min_size=1, max_size=16))
    def check(scene, h, flow, signs, sizes):
        nonlocal count, refused, busy
        try:
            scene = scene.replace(solver_method=args.method, solver_detection=args.detection,
                                  **budget)
        except ParameterError as exc:
            _REFUSALS.note(exc)
            assume(False)
        count += 1
        if count % 250 == 0:
            print(f"... {count} scenes, {refused} refused, {busy} busy, {len(found)} faults",
                  flush=True)
        sizes = sizes if n_steps is not None else None
        outcome = run_case(scene, h, flow, signs, args.time_limit, sizes, n_steps)
        refused += outcome.refused
        busy += outcome.busy
        if outcome.refusal is not None:
            print(f"REFUSED at t = {outcome.t} s: {outcome.refusal}", flush=True)
            print("REPLAY " + case_text(scene, h, flow, signs, args.time_limit, sizes, n_steps),
                  flush=True)
        if outcome.fault is not None:
            found.append(outcome.fault)
            print(outcome.fault, flush=True)
        if outcome.fault is not None or outcome.busy or outcome.cpu > 10.0:
            if outcome.busy:
                print(f"BUSY {outcome.impacts} impacts by t = {outcome.t} s in {outcome.cpu:.1f}"
                      f" s, h = {h} s, flow {flow}: {scene}", flush=True)
            elif outcome.fault is None:
                print(f"SLOW {outcome.cpu:.1f} s, h = {h} s, flow {flow}: {scene}", flush=True)
            print("REPLAY " + case_text(scene, h, flow, signs, args.time_limit, sizes, n_steps),
                  flush=True)

    check()
    print(f"{count} scenes, {refused} refused at a step, {busy} busy (impacts or integration), "
          f"{len(found)} faults; {_REFUSALS.total()} drawn scenes refused up front")
    for name, n in sorted(_REFUSALS.by_name.items(), key=lambda item: -item[1]):
        print(f"  refused up front {n} times: {name}")


if __name__ == "__main__":
    main()
