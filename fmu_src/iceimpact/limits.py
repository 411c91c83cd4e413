"""The work limits of each method: what a scene may ask of a solver so that every simulated second
costs bounded CPU time, and the time resolution of the exact method's root search.

Validation (:mod:`iceimpact.scene`) calls these rules; each refusal names the parameter, its
value, the limit and why (docs/explanation/robustness/limits.md has the measurements
behind each constant). The solvers read only :data:`TIME_RESOLUTION` from here.
"""

from __future__ import annotations

import math
from typing import Protocol

from .contract import (
    CHATTER_FRACTION,
    FLOW_INPUT,
    LINEAR_DRAG,
    METHOD_EXACT,
    METHOD_FIXED_STEP,
    METHOD_ODE,
    QUADRATIC_DRAG,
)
from .errors import ParameterError


class SceneFields(Protocol):
    """A scene as the work limits read it: the fields of :class:`iceimpact.scene.Scene` they
    use, read only (validation calls these rules on a Scene; naming the fields here keeps this
    module below the scene module, which imports it)."""

    @property
    def solver_method(self) -> int: ...  # the method: 1 exact, 2 fixed step, 3 ODE
    @property
    def solver_ode_method(self) -> int: ...  # method 3's integrator
    @property
    def solver_rtol(self) -> float: ...  # method 3's relative tolerance
    @property
    def solver_chatter_fraction(self) -> float: ...  # chatter time / structure period
    @property
    def structure_m(self) -> float: ...  # the structure's mass, kg
    @property
    def structure_mass(self) -> float: ...  # the mass moving with the structure, m + m_a, kg
    @property
    def structure_c(self) -> float: ...  # the structure's damping, N.s/m
    @property
    def structure_k(self) -> float: ...  # the structure's stiffness, N/m
    @property
    def structure_x0(self) -> float: ...  # the structure's initial displacement, m
    @property
    def structure_v0(self) -> float: ...  # the structure's initial velocity, m/s
    @property
    def structure_drag_on(self) -> bool: ...  # the flow drags the structure
    @property
    def structure_drag_B(self) -> float: ...  # Morison B_s, kg/m
    @property
    def structure_drag_b(self) -> float: ...  # Morison b_s, kg/s
    @property
    def omega_n(self) -> float: ...  # the structure's natural circular frequency, rad/s
    @property
    def external(self) -> bool: ...  # the structure lives in another FMU
    @property
    def ice_M(self) -> float: ...  # the ice's mass, kg
    @property
    def ice_v0(self) -> float: ...  # the ice's initial velocity, m/s
    @property
    def drag_model(self) -> int: ...  # the ice's drag law: linear or quadratic
    @property
    def drag_B(self) -> float: ...  # the ice's quadratic drag constant, kg/m
    @property
    def drag_b(self) -> float: ...  # the ice's linearised drag constant, kg/s
    @property
    def drag_v_lin(self) -> float: ...  # the speed of the drag's linearisation, m/s
    @property
    def flow_u(self) -> float: ...  # the flow speed, m/s


def integrates_quadratic_drag(scene: SceneFields) -> bool:
    """Method 1 or 3 with quadratic drag: a rate 2 B |speed| / M is integrated."""
    return (scene.drag_model == QUADRATIC_DRAG
            and scene.solver_method in (METHOD_EXACT, METHOD_ODE))


def drag_rate(scene: SceneFields, speed: float) -> float:
    """Relaxation rate 2 B speed / M of the quadratic drag at a relative speed (1/s)."""
    return 2.0 * scene.drag_B * speed / scene.ice_M


def drag_rate_text(scene: SceneFields, limit: float, what: str) -> str:
    return (f"{what} <= {limit:.3g} m/s with quadratic drag and solver.method = "
            f"{scene.solver_method}{_integrator_text(scene)}: the drag rate 2 B {what} / ice.M "
            f"must stay <= {rate_limit(scene):g} 1/s, the stiffest the integration of "
            f"the drag finishes in bounded time (B = fluid.rho ice.Cd ice.A / 2 = "
            f"{scene.drag_B:.6g} kg/m){_implicit_hint(scene)}")


def rate_limit(scene: SceneFields) -> float:
    """Largest relaxation rate (1/s) the scene's method integrates in bounded work: method 3
    with an explicit integrator (RK45, DOP853), ODE_EXPLICIT_RATE_MAX; method 1 and method 3
    with LSODA or Radau, DRAG_RATE_MAX (docs/explanation/robustness/limits.md). Method 1's sticking
    phase is held
    to the lower TAYLOR_RATE_MAX besides (check_sticking_rate)."""
    if scene.solver_method == METHOD_ODE and scene.solver_ode_method in EXPLICIT_ODE_METHODS:
        return ODE_EXPLICIT_RATE_MAX
    return DRAG_RATE_MAX


def omega_limit(scene: SceneFields) -> float:
    """Largest omega_n (rad/s) the scene's method resolves in bounded work: OMEGA_MAX_EXACT
    times min(1, solver.chatter_fraction / 1e-2) (method 1), OMEGA_MAX_ODE (method 3), and
    with Radau RADAU_OMEGA_MAX scaled by (solver.rtol / RADAU_OMEGA_RTOL)^(1/4), its steps per
    period scaling as rtol^(-1/4), up to OMEGA_MAX_ODE (docs/explanation/robustness/limits.md)."""
    if scene.solver_method == METHOD_EXACT:
        # the chatter time scales with solver.chatter_fraction: a smaller one lowers the limit
        # (a larger one keeps it: stiffer structures are untested)
        return OMEGA_MAX_EXACT * min(1.0, scene.solver_chatter_fraction / CHATTER_FRACTION)
    if scene.solver_method == METHOD_ODE and scene.solver_ode_method == RADAU_ODE_METHOD:
        scale = (scene.solver_rtol / RADAU_OMEGA_RTOL) ** 0.25
        return min(OMEGA_MAX_ODE, RADAU_OMEGA_MAX * scale)
    return OMEGA_MAX_ODE


def integrates_taylor_sticking(scene: SceneFields) -> bool:
    """Method 1 with quadratic drag and the built-in structure: its sticking phase is integrated
    by explicit Taylor steps (solvers/search/taylor.py)."""
    return (scene.solver_method == METHOD_EXACT and scene.drag_model == QUADRATIC_DRAG
            and not scene.external)


def sticking_rates(scene: SceneFields, speed: float) -> tuple[float, float, float]:
    """The rates (1/s) of method 1's quadratic-drag sticking equation (m + M) x'' + c x' + k x =
    (B + B_s) |u - x'| (u - x') at a relative speed |u - x'| = ``speed`` (m/s): its stiffness
    sqrt(k / (m + M)), damping c / (m + M) and drag 2 (B + B_s) speed / (m + M) (the drag's
    linearisation; B_s the Morison drag on the structure, 0 when off)."""
    s = scene
    total, B = _sticking_constants(s)
    return (math.sqrt(s.structure_k / total), s.structure_c / total, 2.0 * B * speed / total)


def _sticking_constants(scene: SceneFields) -> tuple[float, float]:
    """The mass m + M (kg, m with its added mass) and drag constant B + B_s (kg/m) of method 1's
    quadratic-drag sticking equation."""
    s = scene
    return (s.structure_mass + s.ice_M,
            s.drag_B + (s.structure_drag_B if s.structure_drag_on else 0.0))


def check_sticking_rate(scene: SceneFields, speed: float, flow: float | None = None) -> None:
    """Refuse a method-1 quadratic-drag scene whose sticking phase the Taylor steps cannot
    integrate in bounded work: the largest of :func:`sticking_rates` above TAYLOR_RATE_MAX, the
    drag's at ``speed`` (the scene's speed bound up front; |flow.u| for a new ``flow``)."""
    s = scene
    stiffness, damping, drag = sticking_rates(s, speed)
    rate = max(stiffness, damping, drag)
    if rate <= TAYLOR_RATE_MAX:
        return
    why = ("the sticking phase is integrated by explicit Taylor steps of about 5 / rate, "
           f"up to ~{TAYLOR_COST:g} s of CPU x rate per simulated second")
    total, B = _sticking_constants(s)
    if flow is not None and drag > TAYLOR_RATE_MAX:
        limit = TAYLOR_RATE_MAX * total / (2.0 * B)
        raise ParameterError(FLOW_INPUT.name, flow,
                             f"|flow.u| <= {limit:.3g} m/s with quadratic drag and "
                             f"solver.method = 1: the sticking drag rate 2 (B + B_s) |flow.u| / "
                             f"(m + M) = {drag:.3g} 1/s must stay <= {TAYLOR_RATE_MAX:g} 1/s "
                             f"(B + B_s = {B:.6g} kg/m, m + M = {total:.6g} kg): {why}")
    raise ParameterError(
        STICKING_RATE, rate,
        f"<= {TAYLOR_RATE_MAX:g} 1/s with quadratic drag and solver.method = 1 (here "
        f"sqrt(structure.k / (m + M)) = {stiffness:.3g} rad/s, structure.c / (m + M) = "
        f"{damping:.3g} 1/s, 2 (B + B_s) speed / (m + M) = {drag:.3g} 1/s with B + B_s = "
        f"{B:.6g} kg/m, m + M = {total:.6g} kg, speed = {_SPEED_BOUND} = {speed:.6g} m/s): "
        f"{why}; use drag.model = 1, whose sticking phase is closed form")


def _integrator_text(scene: SceneFields) -> str:
    """The integrator a method-3 rate limit depends on, for messages ('' for method 1)."""
    if scene.solver_method != METHOD_ODE:
        return ""
    return (f" and solver.ode_method = {scene.solver_ode_method} ("
            f"{EXPLICIT_ODE_METHODS.get(scene.solver_ode_method, 'implicit')})")


def _implicit_hint(scene: SceneFields) -> str:
    """What to do instead, when an implicit integrator would accept the rate."""
    if scene.solver_method == METHOD_ODE and scene.solver_ode_method in EXPLICIT_ODE_METHODS:
        return (f"; solver.ode_method = 3 (LSODA, which switches to an implicit method when "
                f"stiff) accepts rates up to {DRAG_RATE_MAX:g} 1/s")
    return ""


def integrated_rate(scene: SceneFields, u: float, ice_speed: float | None = None,
                    structure_speed: float | None = None, together: bool = False) -> float:
    """The fastest relaxation rate (1/s) method 3 integrates at flow speed u, the largest of
    the rates the validation bounds (check_work): the structure's damping c / m, the ice's
    drag (b / M linearised, eq. 4-5; 2 B ice_speed / M quadratic, eq. 2-3) and the Morison drag
    on the structure (b_s / (m + m_a); 2 B_s structure_speed / (m + m_a)). The quadratic laws'
    speeds relative to the flow default to the bounds validation uses (_SPEED_BOUND with this
    flow; max(|u|, |u - structure.v0|)). 0 if none acts.

    ``together``: the rate of the bodies moving together (the sticking phase,
    ``(m + m_a + M) x'' + c x' + k x = F_drag(x') + F_s(x')``), whose dampings add on the whole
    moving mass: (c + b + b_s) / (m + m_a + M) linearised, (c + 2 (B + B_s) speed) /
    (m + m_a + M) quadratic, ``ice_speed`` being the bodies' speed relative to the flow
    (default as above): minus the velocity's coefficient in the Jacobian of the sticking
    right-hand side. As a mediant of (c + b_s) / (m + m_a) and b / M (or 2 B speed / M) it
    never exceeds the larger of them: the rates the rules bound (c / m, b_s / (m + m_a) and
    b / M each), or twice that with a Morison drag. A light floe on a heavy structure
    integrates b / M in flight but only b / (m + M) stuck (a 0.34 mg floe on a 1.8 g
    structure: 2.9e5 and 53 1/s)."""
    s = scene
    if together:
        damping = s.structure_c
        if s.drag_model == QUADRATIC_DRAG:
            B = s.drag_B + (s.structure_drag_B if s.structure_drag_on else 0.0)
            damping += 2.0 * B * (_speed_bound(s, u) if ice_speed is None else ice_speed)
        else:
            damping += s.drag_b + (s.structure_drag_b if s.structure_drag_on else 0.0)
        return damping / (s.structure_mass + s.ice_M)
    rates = [s.structure_c / s.structure_m]
    if s.drag_model == QUADRATIC_DRAG:
        rates.append(drag_rate(s, _speed_bound(s, u) if ice_speed is None else ice_speed))
    else:
        rates.append(s.drag_b / s.ice_M)
    if s.structure_drag_on:
        speed = (max(abs(u), abs(u - s.structure_v0)) if structure_speed is None
                 else structure_speed)
        rates.append(2.0 * s.structure_drag_B * speed / s.structure_mass
                     if s.drag_model == QUADRATIC_DRAG
                     else s.structure_drag_b / s.structure_mass)
    return max(rates)


def _speed_bound(scene: SceneFields, u: float) -> float:
    """The speed relative to a flow u that the integrated quadratic drag can meet (m/s): the
    ice's own, or what an impact gives it, up to twice the structure's speed, which never
    exceeds sqrt(v0^2 + omega_n^2 x0^2) (its energy only decays in free motion)."""
    s = scene
    return abs(u) + abs(s.ice_v0) + 2.0 * math.hypot(s.structure_v0, s.omega_n * s.structure_x0)


def _structure_drag_rate(scene: SceneFields, speed: float) -> float | None:
    """Relaxation rate of the Morison drag on the structure that a method integrates (1/s):
    2 B_s speed / (m + m_a) with quadratic drag (methods 1 and 3), b_s / (m + m_a) with the
    linearised drag (method 3); None where closed forms carry it."""
    s = scene
    if s.drag_model == QUADRATIC_DRAG and s.solver_method in (METHOD_EXACT, METHOD_ODE):
        return 2.0 * s.structure_drag_B * speed / s.structure_mass
    if s.drag_model == LINEAR_DRAG and s.solver_method == METHOD_ODE:
        return s.structure_drag_b / s.structure_mass
    return None


def check_structure_drag_rate(scene: SceneFields, speed: float, name: str) -> None:
    """Refuse a Morison drag on the structure too stiff for the explicit integrators (the same
    DRAG_RATE_MAX as the ice's drag); ``speed`` is the relative speed it acts at (m/s), named
    ``name`` (the quadratic law's rate grows with it; the linearised one's is a constant)."""
    rate = _structure_drag_rate(scene, speed)
    if rate is not None and rate > rate_limit(scene):
        quadratic = scene.drag_model == QUADRATIC_DRAG
        raise ParameterError(name if quadratic else "B_s * drag.v_lin / (structure.m + m_a)",
                             speed if quadratic else rate,
                             f"a Morison drag rate on the structure <= {rate_limit(scene):g} "
                             f"1/s with drag.model = {scene.drag_model} and solver.method = "
                             f"{scene.solver_method}{_integrator_text(scene)} (rate {rate:.3g} "
                             "1/s: 2 B_s |speed| / (m + m_a) quadratic, b_s / (m + m_a) "
                             "linearised, B_s = fluid.rho structure.Cd structure.A / 2 = "
                             f"{scene.structure_drag_B:.6g} kg/m): the explicit integration of "
                             f"the drag finishes in bounded time only below it"
                             f"{_implicit_hint(scene)}")


def check_work(scene: SceneFields) -> None:
    """Refuse scenes whose time scales the method cannot resolve in bounded work (see
    OMEGA_MAX_EXACT, OMEGA_MAX_ODE, DRAG_RATE_MAX; docs/explanation/robustness/limits.md)."""
    s = scene
    if s.solver_method == METHOD_FIXED_STEP:
        return  # closed forms (and eq. 36) on a grid: work is the number of grid points
    radau = s.solver_method == METHOD_ODE and s.solver_ode_method == RADAU_ODE_METHOD
    if radau and s.solver_rtol < RADAU_RTOL_MIN:
        raise ParameterError("solver.rtol", s.solver_rtol,
                             f">= {RADAU_RTOL_MIN:g} with solver.method = 3{_RADAU_TEXT}: its "
                             "steps grow as rtol^(-1/4) (an error estimate of order 3), "
                             "~500-800 steps (~0.1 s of CPU) per change of the flow at this "
                             "limit; solver.ode_method = 3 (LSODA) accepts tighter tolerances")
    if (s.solver_method == METHOD_EXACT and s.drag_model == LINEAR_DRAG
            and s.drag_b / s.ice_M > EXACT_DRAG_RATE_MAX):
        raise ParameterError("B * drag.v_lin / ice.M", s.drag_b / s.ice_M,
                             f"<= {EXACT_DRAG_RATE_MAX:.3g} 1/s with linear drag and "
                             "solver.method = 1: the ice's relaxation time M / b must stay above "
                             f"the time resolution of the exact method's root search "
                             f"({TIME_RESOLUTION:g} s), which cannot resolve a faster "
                             "relaxation; use solver.method = 2, whose closed forms on a grid "
                             "need no root search (B = fluid.rho ice.Cd ice.A / 2 = "
                             f"{s.drag_B:.6g} kg/m, drag.v_lin = {s.drag_v_lin:.6g} m/s, "
                             f"ice.M = {s.ice_M:.6g} kg)")
    omega_max = omega_limit(s)
    if s.omega_n > omega_max:
        why = ("the chatter time (solver.chatter_fraction = "
               f"{s.solver_chatter_fraction:g} of the structure's period) must stay above the time "
               f"resolution of the exact method's root search ({TIME_RESOLUTION:g} s x t) "
               f"up to t = {RESOLVED_HORIZON:g} s") if s.solver_method == METHOD_EXACT else (
               f"Radau takes ~{RADAU_STEPS_PER_PERIOD:g} ({RADAU_OMEGA_RTOL:g} / solver.rtol)"
               f"^(1/4) steps per period of the structure (here solver.rtol = "
               f"{s.solver_rtol:g}); use "
               "solver.ode_method = 3 (LSODA) or solver.method = 1 or 2 for a stiffer "
               "structure") if radau else (
               "the ODE integrators take 10-20 steps per period of the structure; use "
               "solver.method = 1 or 2 for a stiffer structure")
        raise ParameterError("sqrt(structure.k / structure.m)", s.omega_n,
                             f"omega_n <= {omega_max:.3g} rad/s with solver.method = "
                             f"{s.solver_method}{_RADAU_TEXT if radau else ''}: {why}")
    if integrates_quadratic_drag(s):
        speed = _speed_bound(s, s.flow_u)
        if drag_rate(s, speed) > rate_limit(s):
            limit = rate_limit(s) * s.ice_M / (2.0 * s.drag_B)
            raise ParameterError(_SPEED_BOUND, speed, drag_rate_text(s, limit, "speed"))
    if s.solver_method == METHOD_ODE and s.structure_c / s.structure_m > rate_limit(s):
        # an over-damped structure relaxes at up to c / m: the same step bound as a drag rate
        raise ParameterError("structure.c / structure.m", s.structure_c / s.structure_m,
                             f"<= {rate_limit(s):g} 1/s with solver.method = 3"
                             f"{_integrator_text(s)}: the integration of the structure's "
                             "damping finishes in bounded time only below this rate; use "
                             f"solver.method = 1 or 2{_implicit_hint(s)}")
    if s.solver_method == METHOD_ODE and s.drag_model == LINEAR_DRAG:
        if s.drag_b / s.ice_M > rate_limit(s):
            raise ParameterError("B * drag.v_lin / ice.M", s.drag_b / s.ice_M,
                                 f"<= {rate_limit(s):g} 1/s with solver.method = 3"
                                 f"{_integrator_text(s)}: the integration of the drag finishes "
                                 f"in bounded time only below this rate{_implicit_hint(s)}")
    if s.structure_drag_on:
        check_structure_drag_rate(s, max(abs(s.flow_u), abs(s.flow_u - s.structure_v0)),
                                   "max(|flow.u|, |flow.u - structure.v0|)")
    if integrates_taylor_sticking(s):  # after the rules of its parts, the flight's included
        check_sticking_rate(s, _speed_bound(s, s.flow_u))


#: The relative speed bound of the quadratic-drag rate rule (check_work), as a user reads it.
_SPEED_BOUND = "|flow.u| + |ice.v0| + 2 sqrt(structure.v0^2 + (omega_n structure.x0)^2)"

#: The explicit Euler step of the quadratic drag (eq. 36) maps r = w - u to r (1 - q |r|) with
#: q = (B/M) dt: |r| grows (and overflows) once q |r| exceeds this (method 2).
EULER_STABILITY_LIMIT = 2.0

#: Why a combination of finite parameters can still be refused.
OVERFLOW = "this scene's scales overflow double precision"

#: Time resolution of the exact method's root search at t <= 1 s (s): a few ulps of the time.
TIME_RESOLUTION = 8.9e-16
#: Simulated time up to which the exact method must resolve the structure's motion (s).
RESOLVED_HORIZON = 1e6
#: Largest linear drag rate b / M (1/s) of method 1: the ice's relaxation time must stay above
#: the root search's time resolution. Beyond it the rounding of the relaxed velocity w - u
#: (a few ulps of u) times b / M is an acceleration bound that the search's steps shrink to
#: (b / M = 3.5e37 1/s: no progress past 1e-9 s in 10 s of CPU; 1e27: 18 s for 300 s).
EXACT_DRAG_RATE_MAX = 1.0 / TIME_RESOLUTION
#: Largest omega_n (rad/s) of methods 1 and 3. Method 1 closes every bounce shorter than the
#: chatter time (1e-2 of the structure's period, contract.CHATTER_FRACTION) and resolves
#: longer ones with its root search, whose time resolution is TIME_RESOLUTION * max(1, t). Above
#: this omega_n the chatter time 2 pi 1e-2 / omega_n falls below that resolution before
#: RESOLVED_HORIZON: bounces in between can be neither closed nor resolved and the search creeps
#: at the resolution (omega_n = 1e15 rad/s: no progress in 20 s). Method 3 is held to its own,
#: lower limit (OMEGA_MAX_ODE). This is the limit at the default solver.chatter_fraction;
#: omega_limit scales it with the scene's.
OMEGA_MAX_EXACT = 2.0 * math.pi * 1e-2 / (TIME_RESOLUTION * RESOLVED_HORIZON)  # 7.06e7 rad/s
#: Largest omega_n (rad/s) of method 3: its integrators take ~10-20 steps per period of the
#: structure, so its work grows with omega_n x horizon; 1e4 rad/s costs ~2.5 s of wall time
#: per simulated second (one 1 s solve_ivp chunk is integrated whole even for a 1 ms step;
#: 1e5: ~10 s, 1e6: no 1 s chunk within 20 s).
OMEGA_MAX_ODE = 1e4
#: Largest relaxation rate of the drag (1/s) for the integrated phases: the ice's flight in
#: method 3 (b/M, or 2 B |w - u| / M) and the quadratic-drag sticking phase of method 1
#: (2 B |v - u| / (m + M) <= 2 B |v - u| / M; its own rule, TAYLOR_RATE_MAX, is lower). Their
#: explicit integrators (DOP853, RK45) are stable only for steps below ~3.3 / rate: at 1e6 1/s
#: that is ~3e5 steps (about 10 s of wall time) per simulated second; flow.u = 1e12 m/s (rate
#: 6e11 1/s) did not finish 20 ms in 60 s.
DRAG_RATE_MAX = 1e6
#: Largest rate (1/s) of method 1's quadratic-drag sticking phase (sticking_rates: the bodies'
#: stiffness sqrt(k / (m + M)), damping c / (m + M) and drag 2 (B + B_s) speed / (m + M)). Its
#: explicit Taylor steps (solvers/search/taylor.py, order 36 at a tolerance of 1e-16) are about
#: 5 / rate long whatever the motion: their last terms (rate h)^36 / 36! must stay below 1e-16
#: of it, and a higher order's longer steps would lose to cancellation (terms up to
#: e^(rate h)) the digits they gain. Measured 0.1 to 0.3 steps and up to TAYLOR_COST s of CPU
#: x rate per simulated second at 1e5 to 1e6 1/s (tools/taylor_rate_cost.py,
#: docs/explanation/robustness/limits.md), so that at this limit 1 s of simulated time costs at
#: most ~2 s of CPU
#: (at 1e6 1/s, the limit before, 4-11 s in those scenes; the random search's scenes at
#: 3.7e5-5.4e5 1/s took 4.5-10 s).
TAYLOR_RATE_MAX = 1e5
#: Largest rate (1/s) of a mode of the modal structure, omega_k (zeta_k + sqrt(zeta_k^2 + 1)):
#: the riding phase's Taylor steps (solvers/search/modal_taylor.py) span at most 4 / rate each
#: and are made from Python one at a time (~5-10 us a step with 1 to 5 modes, measured ~100
#: steps a simulated second at 70 1/s), so 2e4 1/s costs up to a few seconds of CPU per
#: simulated second of riding.
MODAL_RATE_MAX = 2e4
#: CPU time per (1/s) of rate per simulated second of method 1's sticking Taylor steps (s), the
#: largest measured at 1e5 1/s and above (1.1e-5 to 1.7e-5 s; up to 3e-5 s at 1e4 1/s, where
#: the flow changes at every 1 ms step add a fixed cost), on a machine shared with other work.
TAYLOR_COST = 2e-5
#: The rate rule of method 1's quadratic-drag sticking phase (check_sticking_rate), as a user
#: reads it.
STICKING_RATE = ("max(sqrt(structure.k / (m + M)), structure.c / (m + M), "
                 "2 (B + B_s) speed / (m + M))")
#: solver.ode_method values whose integrators are explicit (method 3), by name.
EXPLICIT_ODE_METHODS = {1: "RK45", 2: "DOP853"}
#: Largest relaxation rate (1/s) of method 3 with an explicit integrator (RK45, DOP853): the
#: rate rules above (c / m, b / M, 2 B speed / M, the Morison drag on the structure) at this
#: limit instead of DRAG_RATE_MAX. Near its stability bound such an integrator costs about
#: 3e-5 s of CPU x rate per simulated second (measured 2.6e-5 to 3.5e-5 s at 2.9e5 1/s in
#: the four stiff scene kinds of docs/explanation/robustness/limits.md, with the flow reversed
#: every 1 ms step:
#: 3.3-10.1 s per simulated second at 2.9e5 1/s, 28 s at 1e6; tools/ode_rate_cost.py), so that
#: 1 s of simulated time costs at most ~10 s of CPU. LSODA (solver.ode_method = 3) switches to
#: an implicit method when stiff: at most 7.6 s per simulated second at 9.9e5 1/s in the same
#: scenes; it and Radau keep DRAG_RATE_MAX.
ODE_EXPLICIT_RATE_MAX = 3e5
#: solver.ode_method of Radau (method 3).
RADAU_ODE_METHOD = 4
#: scipy's Radau estimates a step's error with an embedded formula of order 3 (error ~ h^4),
#: so its steps per period of the structure, and per relaxation after a change of the flow,
#: grow as rtol^(-1/4) whatever the rate (measured: x3.2 per two decades of rtol from 1e-4 to
#: 1e-12), each step ~150 us of CPU (benchmarks/implicit_cost.py). At solver.rtol = 1e-8: ~350
#: steps per period of a ringing structure (RADAU_STEPS_PER_PERIOD), and 150 (linear
#: right-hand side) to 300 (quadratic drag) steps to resolve the relaxation that follows each
#: flow change, at any rate from 1e3 to 1e6 1/s. Smallest solver.rtol of Radau: a flow change
#: then costs at most ~800 steps (~0.12 s of CPU); 1e-12: 1500-2500 steps, 0.2-0.4 s.
RADAU_RTOL_MIN = 1e-10
#: Steps of Radau per period of a ringing structure at solver.rtol = RADAU_OMEGA_RTOL (measured
#: 350-365 at omega_n = 1e3 and 1e4 rad/s, zeta = 0.01).
RADAU_STEPS_PER_PERIOD = 350
#: Largest omega_n (rad/s) of Radau at solver.rtol = RADAU_OMEGA_RTOL, scaled as rtol^(1/4)
#: (omega_limit): 1e3 rad/s rings 160 periods, ~6e4 steps, 7-9 s of CPU per simulated second;
#: OMEGA_MAX_ODE = 1e4 rad/s cost 82-84 s (benchmarks/results/implicit_cost.md).
RADAU_OMEGA_MAX = 1e3
#: The solver.rtol at which RADAU_OMEGA_MAX and RADAU_STEPS_PER_PERIOD were measured.
RADAU_OMEGA_RTOL = 1e-8
_RADAU_TEXT = f" and solver.ode_method = {RADAU_ODE_METHOD} (Radau)"
