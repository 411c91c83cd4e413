"""Random search for faults at the extremes: hypothesis scenes, each run with a time limit.

    python tools/random_search.py --method 1 --seed 23 --examples 2000
    python tools/random_search.py --method 1 --seed 5 --examples 3000 --scales --flows

Each random scene (the strategy of tests/test_properties.py, with the chosen solver method;
method 2 uses the gap-sign test unless --detection 1) runs for 3 s (method 3: 1 s) at a random
communication step of 1 ms to 10 s, with a limit of 30 s of CPU time (the machine may be
shared: wall time would flag scenes slowed by other work).

``--scales`` draws the scales out to what validation accepts (omega_n up to the method's limit,
masses from 1e-6 to 1e9 kg, flows up to the drag-rate limit, steps down to 0.1 ms); ``--flows``
drives the flow input with a random sequence: constant, reversing at every step, random signs,
zero, reversed one step in four. Scenes the model refuses (ParameterError, at the start or at a
step, or a SolverError naming the limit, such as method 2's unstable Euler step) are
counted and skipped.

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
from pathlib import Path

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
from iceimpact.solvers.contact_rules import chatter_time
from iceimpact.solvers.ode import ATOL_SCALE, ODE_METHODS, PARTING_NOISE, STABLE_STEP

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_properties import scenes  # noqa: E402  (the property tests' scene strategies)

TIME_LIMIT = 30.0  # s of CPU time per scene (not wall time: the machine may be shared)
# m; method 3: 10 atol; method 2 reports its grid penetration instead
GAP_TOLERANCE = {1: 1e-12, 2: math.inf, 3: 1e-10}
# relative to the scene's momentum scale: rounding (methods 1, 2), integration error (3)
IMPULSE_TOLERANCE = {1: 1e-9, 2: 1e-9, 3: 1e-5}
# relative growth of the energy at u = 0 (docs/robustness.md, the extremes matrix)
ENERGY_TOLERANCE = {1: 1e-9, 2: 1e-9, 3: 1e-5}
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
FLOWS = ("constant", "reversing", "random signs", "zero", "reversed 1 in 4")
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


def flow_at(kind: str, i: int, u: float, signs: list[bool]) -> float:
    """Flow speed of communication step i under a sequence ``kind`` around speed u."""
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
    """Mechanical energy 1/2 m v^2 + 1/2 k x^2 + 1/2 M w^2, J."""
    return 0.5 * (scene.structure_m * s.v ** 2 + scene.structure_k * s.x ** 2
                  + scene.ice_M * s.w ** 2)


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


def busy_with_impacts(scene: Scene, t: float, impacts: int, cpu: float,
                      late_impacts: int, late_cpu: float) -> bool:
    """A run out of CPU time is busy with its impacts, not stalled, when its work went into
    impacts at the rate the contact rules allow: ``impacts`` by simulated time t at most one
    per chatter time (the chatter closure ends the bouncing of bodies pressed together once a
    bounce would be shorter than CHATTER_FRACTION of the structure's period, docs/robustness.md
    "Many real impacts at a stiff structure"), and at most IMPACT_WORK s of CPU each, over the
    whole run (``cpu``) and over its second half (``late_impacts`` in ``late_cpu``: a run
    stalled after many quick impacts is not busy). Such a run is bounded: its CPU per
    simulated second is at most IMPACT_WORK / chatter_time; it is slow only because it resolves
    up to ~16 omega_n real impacts per simulated second."""
    if late_impacts <= 0 or t <= 0.0:
        return False
    omega_n = math.sqrt(scene.structure_k / scene.structure_m)
    return (impacts <= t / chatter_time(omega_n) + 1.0 and cpu <= IMPACT_WORK * impacts
            and late_cpu <= IMPACT_WORK * late_impacts)


def busy_integrating(scene: Scene, u: float, t: float, nfev: int, steps: int) -> bool:
    """A method-3 run (its explicit integrator, the search's DOP853) out of CPU time is busy
    integrating, not stalled, when its right-hand-side evaluations up to simulated time t keep
    within what its rate rule allows: ODE_WORK evaluations per unit of the fastest rate it
    integrates (``integrated_rate`` at the flow speed u: DOP853 makes 15 evaluations per step
    of at most STABLE_STEP / rate = 1 / (5 rate) s, 3 rate per simulated second, plus its
    restarts at impacts), ODE_RESTART_WORK per communication step (a flow change restarts the
    integration) and ODE_WORK_FLOOR. Such a run costs up to ~10 s of CPU per simulated second
    at the rate limit, 3e5 1/s (docs/robustness.md, fix 30, and Open)."""
    if (scene.solver_method != 3 or ODE_METHODS[scene.solver_ode_method] not in STABLE_STEP
            or t <= 0.0):
        return False
    rate = integrated_rate(scene, u)
    return nfev <= ODE_WORK * rate * t + ODE_RESTART_WORK * steps + ODE_WORK_FLOOR


def run_case(scene: Scene, h: float, flow: str, signs: list[bool],
             time_limit: float = TIME_LIMIT) -> Outcome:
    """Run one scene of the search (its method is ``scene.solver_method``) at communication step
    h under the flow sequence ``flow`` (with ``signs`` for "random signs"), checking every step:
    finite outputs, gap, contact impulse, energy at u = 0. Stops at the first fault, at a
    refused step, or after ``time_limit`` s of CPU time (a TIMEOUT fault)."""
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
    fault, refused, min_gap, busy = None, False, math.inf, False
    reached = None  # (simulated time, impacts) where a run out of CPU time stood
    start = time.process_time()
    alarm = _HalfwayAlarm(sim)
    previous = signal.signal(signal.SIGPROF, alarm)
    signal.setitimer(signal.ITIMER_PROF, 0.5 * time_limit, 0.5 * time_limit)
    i = 0
    try:
        while sim.t < t_end - 1e-12:
            u = flow_at(flow, i, u0, signs)
            i += 1
            try:
                r = sim.advance(min(h, t_end - sim.t), u)
            except (ParameterError, SolverError):  # a refusal that names the limit
                refused = True
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
            if flow == "zero" and e_now > (e_last + ENERGY_TOLERANCE[method] * e_scale
                                           + floor):
                raise AssertionError(f"energy created at u = 0: {e_last} -> {e_now} J "
                                     f"at t = {r.t}")
            e_last, last = e_now, s
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
        fault = f"FAIL {exc!r}, h = {h} s, flow {flow}: {scene}"
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0.0)
        signal.signal(signal.SIGPROF, previous)
    t_out, impacts_out = reached or (sim.t, sim.impact_count)
    return Outcome(fault, refused, time.process_time() - start, t_out, min_gap, impacts_out,
                   busy)


def case_text(scene: Scene, h: float, flow: str, signs: list[bool],
              time_limit: float = TIME_LIMIT) -> str:
    """One case as JSON, every float at repr() precision (what :func:`replay` reads)."""
    return json.dumps({"scene": dataclasses.asdict(scene), "h": h, "flow": flow,
                       "signs": list(signs), "time_limit": time_limit})


def replay(text: str) -> Outcome:
    """Re-run one case printed by the search (its ``REPLAY`` line's JSON, or the dict); a
    scene the validation refuses gives an outcome "REFUSED up front: <message>"."""
    case = json.loads(text) if isinstance(text, str) else text
    try:
        scene = Scene(**case["scene"])
    except ParameterError as exc:  # a scene the validation now refuses up front
        return Outcome(f"REFUSED up front: {exc}", True, 0.0, 0.0, math.inf)
    return run_case(scene, case["h"], case["flow"], case["signs"],
                    case.get("time_limit", TIME_LIMIT))


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
    strategy = scale_scenes(args.method) if args.scales else scenes()
    steps = [1e-4, 1e-3, 0.01, 0.37, 10.0] if args.scales else [1e-3, 0.01, 0.37, 10.0]
    flows = st.sampled_from(FLOWS) if args.flows else st.just("constant")

    @seed(args.seed)
    @settings(max_examples=args.examples, deadline=None, database=None,
              suppress_health_check=list(HealthCheck))
    @given(scene=strategy, h=st.sampled_from(steps), flow=flows,
           signs=st.lists(st.booleans(), min_size=1, max_size=16))
    def check(scene, h, flow, signs):
        nonlocal count, refused, busy
        try:
            scene = scene.replace(solver_method=args.method, solver_detection=args.detection)
        except ParameterError:
            assume(False)
        count += 1
        if count % 250 == 0:
            print(f"... {count} scenes, {refused} refused, {busy} busy, {len(found)} faults",
                  flush=True)
        outcome = run_case(scene, h, flow, signs, args.time_limit)
        refused += outcome.refused
        busy += outcome.busy
        if outcome.fault is not None:
            found.append(outcome.fault)
            print(outcome.fault, flush=True)
        if outcome.fault is not None or outcome.busy or outcome.cpu > 10.0:
            if outcome.busy:
                print(f"BUSY {outcome.impacts} impacts by t = {outcome.t} s in {outcome.cpu:.1f}"
                      f" s, h = {h} s, flow {flow}: {scene}", flush=True)
            elif outcome.fault is None:
                print(f"SLOW {outcome.cpu:.1f} s, h = {h} s, flow {flow}: {scene}", flush=True)
            print("REPLAY " + case_text(scene, h, flow, signs, args.time_limit), flush=True)

    check()
    print(f"{count} scenes, {refused} refused at a step, {busy} busy (impacts or integration), "
          f"{len(found)} faults")


if __name__ == "__main__":
    main()
