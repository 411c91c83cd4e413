"""The exact method's quadratic-drag sticking phase (Taylor steps, solvers/search/taylor.py)
against an independent integration: scipy's DOP853 at rtol 1e-12 on the sticking equation
written out here,

    (m + M) x'' + c x' + k x = B |u - x'| (u - x'),   contact force lam = drag - M x'',

restarted where u - x' changes sign (the right-hand side is not smooth there), separation where
lam turns tensile. Positions agree within 1e-9 of their scale, separation times within 1e-9 s.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from iceimpact import Scene, Simulator, SolverError
from iceimpact.solvers.exact import EventSolver, QuadraticStick
from iceimpact.solvers.search.taylor import (
    ORDER,
    StepEnd,
    StickingTaylor,
    TaylorStep,
    horner,
    horner_rows,
)

RTOL = 1e-12


def coefficients(scene: Scene, u: float) -> tuple[float, ...]:
    return (scene.structure_m, scene.structure_c, scene.structure_k, scene.ice_M,
            0.5 * scene.fluid_rho * scene.ice_Cd * scene.ice_A, u)


def reference(coeffs, x0: float, v0: float, t_end: float, t0: float = 0.0):
    """Sticking from (x0, v0) at t0 to t_end or separation: (dense pieces, separation or None,
    the state [x, v, drag impulse] at the end)."""
    m, c, k, M, B, u = coeffs
    total = m + M
    pieces, t, y = [], t0, [x0, v0, 0.0]
    while True:
        r0 = u - y[1]
        if r0 != 0.0:
            sign = math.copysign(1.0, r0)
        else:  # at u = v (no drag): the sign u - v takes, that of -x'', or of the third
            # derivative's opposite where x'' = 0 to rounding
            accel = (-c * y[1] - k * y[0]) / total
            jerk = (-c * accel - k * y[1]) / total
            small = abs(accel) <= 1e-12 * (c * abs(y[1]) + k * abs(y[0])) / total
            sign = -math.copysign(1.0, jerk if small else accel)

        def rhs(t, y, sign=sign):
            f = sign * B * (u - y[1]) ** 2
            return [y[1], (f - c * y[1] - k * y[0]) / total, f]

        def contact(t, y, sign=sign):
            f = sign * B * (u - y[1]) ** 2
            return f - M * (f - c * y[1] - k * y[0]) / total
        contact.terminal, contact.direction = True, -1.0

        def flip(t, y):
            return u - y[1]
        flip.terminal, flip.direction = True, -sign

        if contact(t, y) < 0.0:  # tensile already: they part at once
            return pieces, t, np.array(y)
        sol = solve_ivp(rhs, (t, t_end), y, method="DOP853", rtol=RTOL,
                        atol=[1e-18, 1e-16, 1e-13], dense_output=True, events=[contact, flip])
        assert sol.success
        pieces.append((t, sol.t[-1], sol.sol))
        if sol.t_events[0].size:
            return pieces, float(sol.t_events[0][0]), sol.y_events[0][0]
        if not sol.t_events[1].size:
            return pieces, None, sol.y[:, -1]
        t, y = float(sol.t_events[1][0]), [sol.y_events[1][0][0], u, sol.y_events[1][0][2]]


def evaluate(pieces, times):
    out = []
    for t in times:
        for lo, hi, sol in pieces:
            if lo <= t <= hi:
                out.append(sol(t))
                break
        else:
            raise AssertionError(f"t = {t} outside the reference")
    return np.array(out)


def segment(scene: Scene, x0: float, v0: float, u: float | None = None) -> QuadraticStick:
    return QuadraticStick(EventSolver(scene).context, 0.0, x0, v0, scene.flow_u if u is None else u)


def compare(scene: Scene, x0: float, v0: float, t_end: float, dt: float = 1e-2):
    """Sample the segment every dt to t_end (or its separation); the worst position and velocity
    errors relative to their scales, the impulse error, the separation times."""
    coeffs = coefficients(scene, scene.flow_u)
    pieces, t_sep_ref, _ = reference(coeffs, x0, v0, t_end)
    seg = segment(scene, x0, v0)
    t_sep = seg.next_event(t_end)
    stop = t_end if t_sep is None else t_sep
    times = np.append(np.arange(dt, stop, dt), stop)
    if t_sep_ref is not None:
        times = times[times <= min(stop, t_sep_ref)]
    got, impulse, before = [], 0.0, 0.0
    for t in times.tolist():  # as the solver asks: the impulse over a step, the state at its end
        impulse += seg.impulse(before, t)
        got.append(seg.state(t)[:2])
        before = t
    got = np.array(got)
    ref = evaluate(pieces, times)
    impulse_ref = (ref[-1, 2] - scene.ice_M * (ref[-1, 1] - v0))
    x_err = np.max(np.abs(got[:, 0] - ref[:, 0])) / np.max(np.abs(ref[:, 0]))
    v_err = np.max(np.abs(got[:, 1] - ref[:, 1])) / np.max(np.abs(ref[:, 1]))
    i_err = abs(impulse - impulse_ref) / max(abs(impulse_ref), 1e-300)
    return x_err, v_err, i_err, t_sep, t_sep_ref, seg


def figure18_anchor():
    """The Figure 18 scene (quadratic drag, e = 0.5) and the anchor of its last sticking phase
    (from 9.77 s on: the bodies stay together)."""
    scene = Scene(drag_model=2, impact_e=0.5)
    sim = Simulator(scene)
    while sim.t < 10.0:
        sim.advance(0.01)
    assert sim.sticking_since == pytest.approx(9.771, abs=1e-3)
    seg = sim.solver.seg
    assert isinstance(seg, QuadraticStick)
    return scene, seg.x0, seg.v0


def heavy_floe():
    """A heavy floe (M = 4 m) at u = 2 m/s, started at its equilibrium with a kick: a large
    swing whose upstream half pulls the structure off the ice."""
    scene = Scene(drag_model=2, ice_M=6400.0, flow_u=2.0)
    return scene, scene.drag_B * 4.0 / scene.structure_k, 0.3


def lockin_area():
    """The lock-in scene (A = 2 m^2) released from rest at x = 0: pushed onto its equilibrium."""
    return Scene(drag_model=2, ice_A=2.0), 0.0, 0.0


def faster_than_flow():
    """Ice faster than a slow flow (v > u: the drag pulls back) on a deflected structure that
    keeps the contact: u - v changes sign while the bodies stick, then they part."""
    return Scene(drag_model=2, flow_u=0.01), 1e-3, 0.05


def parting_below_the_flow_speed():
    """Just slower than the flow (u - v = 1 cm/s) and speeding up (x'' > 0) with the drag only
    just pressing the ice on (B r^2 > M x''): the contact force turns tensile before u - v
    reaches 0, where it would be -M x'' < 0 (so u - v never turns negative while sticking)."""
    scene = Scene(drag_model=2)
    delta = 0.01
    total = scene.structure_m + scene.ice_M
    accel = 1e-4 * scene.drag_B * delta ** 2 / scene.ice_M
    v0 = scene.flow_u - delta
    x0 = (scene.drag_B * delta ** 2 - scene.structure_c * v0 - total * accel) / scene.structure_k
    return scene, x0, v0


def at_the_flow_speed():
    """Starting at v = u (no drag) with no acceleration (k x = -c u): the sign u - v takes comes
    from the third derivative."""
    scene = Scene(drag_model=2)
    return scene, -scene.structure_c * scene.flow_u / scene.structure_k, scene.flow_u


CASES = {"figure18": (figure18_anchor, 30.0), "heavy_floe": (heavy_floe, 5.0),
         "lockin_A2": (lockin_area, 20.0), "faster_than_flow": (faster_than_flow, 5.0),
         "parting_below_flow_speed": (parting_below_the_flow_speed, 5.0),
         "at_flow_speed": (at_the_flow_speed, 5.0)}


@pytest.mark.parametrize("name", list(CASES))
def test_sticking_agrees_with_an_independent_integration(name):
    make, t_end = CASES[name]
    scene, x0, v0 = make()
    x_err, v_err, i_err, t_sep, t_sep_ref, _ = compare(scene, x0, v0, t_end)
    assert x_err < 1e-9 and v_err < 1e-9
    assert i_err < 1e-9
    assert (t_sep is None) == (t_sep_ref is None)
    if t_sep is not None:
        assert abs(t_sep - t_sep_ref) < 1e-9


def test_the_cases_cover_separations_and_sign_changes():
    """What the cases above exercise: separations, and u - v changing sign while sticking."""
    flips = {}
    for name, (make, t_end) in CASES.items():
        scene, x0, v0 = make()
        seg = segment(scene, x0, v0)
        separation = seg.next_event(t_end)
        flips[name] = (sum(s.end is StepEnd.FLIP for s in seg.steps), separation is not None)
    assert flips["figure18"] == (0, False) and flips["lockin_A2"] == (0, False)
    assert flips["heavy_floe"][1]
    assert flips["faster_than_flow"][0] >= 1 and flips["faster_than_flow"][1]
    assert flips["parting_below_flow_speed"] == (0, True)
    assert flips["at_flow_speed"][0] == 0


def test_a_flow_changing_every_step_against_the_reference():
    """The Simulator re-anchors the sticking phase at every flow change (zero-order hold):
    100 steps of 10 ms with a new flow each, then a reversed flow that pulls the ice off."""
    scene = Scene(drag_model=2, impact_e=0.0)
    sim = Simulator(scene)
    while not (sim.sticking and sim.t > 20.0):
        sim.advance(0.01)
    x, v = sim.report.x, sim.report.v
    flows = np.append(0.1 + 0.01 * np.sin(np.arange(100)), -0.2)
    for i, u in enumerate(flows):
        t = sim.t
        rep = sim.advance(0.01, float(u))
        pieces, t_sep, y = reference(coefficients(scene, float(u)), x, v, t + 0.01, t0=t)
        if t_sep is not None:
            assert i == len(flows) - 1 and not rep.sticking
            # the ice is pulled upstream: they part at once
            assert t_sep == t and rep.gap > 0.0
            break
        assert rep.sticking
        assert abs(rep.x - y[0]) < 1e-9 * abs(y[0])
        assert abs(rep.v - y[1]) < 1e-9 * max(abs(y[1]), 1e-3)
        x, v = rep.x, rep.v
    else:
        raise AssertionError("the reversed flow did not separate the bodies")


def test_results_do_not_depend_on_the_communication_step():
    """Steps are taken from the anchor: any sampling gives the same state, to the bit."""
    scene, x0, v0 = heavy_floe()
    ends = []
    for dt in (None, 1e-2, 3.7e-3):
        seg = segment(scene, x0, v0)
        t_sep = seg.next_event(5.0)
        times = [t_sep] if dt is None else list(np.arange(dt, t_sep, dt)) + [t_sep]
        for t in times:
            seg.next_event(t)
            state = seg.state(t)
        ends.append((t_sep, state))
    assert ends[0] == ends[1] == ends[2]


def test_taylor_coefficients_of_a_known_solution():
    """Without drag (B = 0) the bodies together are a damped oscillator: the series is that of
    the closed form, x(t) = e^{-zeta w t} (x0 cos(wd t) + (v0 + zeta w x0) / wd sin(wd t))."""
    total, c, k = 3200.0, 400.0, 1e6
    stepper = StickingTaylor(total, c, k, 0.0, 0.1, 1600.0, max_step=1.0)
    x0, v0 = 1e-3, -0.02
    step = stepper.step(0.0, (x0, v0, 0.0), math.inf, False)
    w = math.sqrt(k / total)
    zeta = c / (2.0 * math.sqrt(k * total))
    wd = w * math.sqrt(1.0 - zeta ** 2)
    for tau in np.linspace(0.0, step.hi, 7):
        exact = math.exp(-zeta * w * tau) * (x0 * math.cos(wd * tau)
                                             + (v0 + zeta * w * x0) / wd * math.sin(wd * tau))
        assert step.state(tau)[0] == pytest.approx(exact, rel=1e-14, abs=1e-17)
    # the step is long: the series is accurate over a large part of a period
    assert step.hi > 0.2 * 2.0 * math.pi / w
    assert step.table.shape == (ORDER + 1, 3)


def test_pure_drag_decay_has_the_closed_form():
    """With k = 0 and c = 0 the pair is a free mass under drag: u - v = r0 / (1 + beta r0 t),
    beta = B / (m + M) (eq. 31-33 with the mass of both bodies)."""
    total, B, u = 3200.0, 500.0, 0.3
    stepper = StickingTaylor(total, 0.0, 0.0, B, u, 1600.0, max_step=math.inf)
    r0 = 0.25
    tau, y = 0.0, (0.0, u - r0, 0.0)
    for _ in range(20):
        step = stepper.step(tau, y, math.inf, False)
        tau, y = step.hi, step.y_hi
    beta = B / total
    assert u - y[1] == pytest.approx(r0 / (1.0 + beta * r0 * tau), rel=1e-13)
    assert y[0] == pytest.approx(u * tau - math.log1p(beta * r0 * tau) / beta, rel=1e-13)


def test_horner():
    assert horner([1.0, -2.0, 3.0], 0.5) == 1.0 - 1.0 + 0.75


def test_horner_rows_is_horner_for_each_row():
    rng = np.random.default_rng(3)
    tables = rng.normal(size=(ORDER + 1, 4, 3))  # order, table, column
    rows, theta = rng.integers(0, 4, 50), rng.uniform(0.0, 1.0, 50)
    want = [[horner(tables[:, r, j].tolist(), t) for j in range(3)]
            for r, t in zip(rows.tolist(), theta.tolist(), strict=True)]
    np.testing.assert_array_equal(horner_rows(tables, rows, theta), want)


def test_steps_that_do_not_advance_the_time_are_refused(monkeypatch):
    """A sticking phase whose Taylor steps stop advancing the time ends in a SolverError (the
    step is refused and changes nothing), not in an endless loop."""
    sim = Simulator(Scene(drag_model=2, ice_z0=0.0, ice_v0=0.0))  # in contact at rest: sticks
    sim.advance(0.01)
    assert sim.sticking
    saved = sim.save()

    def stalled(self, lo, y, until, look_for_separation):
        step = TaylorStep(lo, y)
        step.end = StepEnd.FLIP
        return step
    monkeypatch.setattr(StickingTaylor, "step", stalled)
    monkeypatch.setattr(StickingTaylor, "run", lambda *args: [])  # every step through step()
    with pytest.raises(SolverError, match="stalled"):
        sim.advance(0.01, 0.2)  # a new flow: a new sticking segment, whose steps stall
    assert sim.save()["solver"] == saved["solver"]


@pytest.mark.parametrize("name", list(CASES))
def test_vectorised_states_equal_the_point_by_point_ones(name):
    """run()'s sampling evaluates a sticking phase's Taylor polynomials at all its samples at
    once (QuadraticStick.states_at, impulses_between): the scalar state at each time to the
    bit (Horner's rule, operation for operation), and the impulse to rounding, at times inside
    steps, on step boundaries and at the separation."""
    make, t_end = CASES[name]
    scene, x0, v0 = make()
    vector = segment(scene, x0, v0)
    t_sep = vector.next_event(t_end)
    stop = t_end if t_sep is None else t_sep
    boundaries = [s.lo for s in vector.steps] + [s.hi for s in vector.steps]
    times = np.unique(np.concatenate((np.linspace(0.0, stop, 997), boundaries,
                                      [stop]))).clip(0.0, stop)
    y = vector.states_at(times)
    impulses = vector.impulses_between(times, y)
    scalar = segment(scene, x0, v0)
    assert scalar.next_event(t_end) == t_sep
    want = np.array([scalar._y(t) for t in times.tolist()])
    np.testing.assert_array_equal(y, want)
    want_impulses = [scalar.impulse(a, b) for a, b in zip(times[:-1], times[1:], strict=True)]
    # a piece is a difference of the drag impulse P and of M v: their rounding
    scale = np.max(np.abs(want[:, 2])) + scene.ice_M * np.max(np.abs(want[:, 1]))
    np.testing.assert_allclose(impulses, want_impulses, rtol=0, atol=1e-14 * scale)


def test_the_compiled_kernels_give_the_pure_functions_floats():
    """The Taylor recurrence and Horner's rule compiled by numba (taylor.KERNELS) against the
    same functions run as Python, on random inputs: the same floats."""
    from iceimpact.solvers.search import taylor, taylor_series
    if taylor.KERNELS is None:
        pytest.skip("numba is not installed (or ICEIMPACT_PURE is set): nothing compiled")
    rng = np.random.default_rng(7)
    for _ in range(20):
        x, v, u, drag, c, k = rng.normal(size=6).tolist()
        order_over = (1.0 / rng.uniform(1.0, 1e4) / np.arange(1.0, ORDER + 1)).tolist()
        reciprocals = (1.0 / np.arange(1.0, ORDER + 1)).tolist()
        rs, fs = [0.0] * (ORDER + 1), [0.0] * ORDER
        taylor_series.taylor_recurrence(x, v, u, drag, 1.5 * drag, c, k, order_over, reciprocals,
                                        rs, fs)
        rs_c, fs_c = np.empty(ORDER + 1), np.empty(ORDER)
        taylor.KERNELS.recurrence(x, v, u, drag, 1.5 * drag, c, k, np.array(order_over),
                                  np.array(reciprocals), rs_c, fs_c)
        assert rs_c.tolist() == rs and fs_c.tolist() == fs
    tables = rng.normal(size=(5, ORDER + 1, 3))  # step, order, column
    los = np.sort(rng.uniform(0.0, 1.0, 5))
    hs = rng.uniform(0.05, 0.3, 5)
    his = np.minimum(los + hs, np.append(los[1:], np.inf))
    ends = rng.normal(size=(5, 3))
    tau = np.concatenate(([los[0] - 0.01], np.sort(rng.uniform(0.0, 1.2, 201)), los, his))
    out = np.empty((tau.size, 3))
    taylor.KERNELS.step_states(los, his, hs, tables, ends, tau, out)
    want = []
    for t in tau.tolist():  # the last step starting at or before t (the first if none)
        i = max(int(np.searchsorted(los, t, side="right")) - 1, 0)
        want.append(ends[i].tolist() if t >= his[i] else
                    [horner(tables[i, :, j].tolist(), (t - los[i]) / hs[i]) for j in range(3)])
    assert out.tolist() == want
    table = np.ascontiguousarray(tables[0])
    assert list(taylor.KERNELS.horner_columns(table, 0.37)) == \
        [horner(table[:, j].tolist(), 0.37) for j in range(3)]


def _pure_stepper(monkeypatch, *args, **kwargs) -> StickingTaylor:
    """A StickingTaylor that runs the pure functions (lists, no compiled kernel) in this
    process, whether numba is installed or not."""
    from iceimpact.solvers.search import taylor
    with monkeypatch.context() as patch:
        patch.setattr(taylor, "KERNELS", None)
        return StickingTaylor(*args, **kwargs)


def _random_stepper(rng) -> tuple[tuple, dict, tuple[float, float, float]]:
    """Coefficients over many scales and a state: some at u - v = 0 exactly, some pushed apart
    (the contact force tensile), some with the Morison drag on the structure."""
    m, M = 10.0 ** rng.uniform(0.0, 5.0, 2)
    k = 10.0 ** rng.uniform(-2.0, 8.0)
    c = 0.0 if rng.random() < 0.2 else 10.0 ** rng.uniform(-2.0, 5.0)
    B = 10.0 ** rng.uniform(-1.0, 4.0)
    u = 0.0 if rng.random() < 0.1 else rng.uniform(-2.0, 2.0)
    period = 2.0 * math.pi / math.sqrt(k / (m + M))
    kwargs = {"structure_B": 10.0 ** rng.uniform(-1.0, 3.0)} if rng.random() < 0.3 else {}
    x = rng.normal() * 10.0 ** rng.uniform(-6.0, 0.0)
    v = u if rng.random() < 0.15 else u + rng.normal() * 10.0 ** rng.uniform(-6.0, 0.5)
    return (m + M, c, k, B, u, M, period), kwargs, (x, v, rng.normal())


def test_the_compiled_step_gives_the_pure_functions_floats(monkeypatch):
    """ordinary_step compiled by numba (taylor.KERNELS) against the same function run as
    Python (lists where the pure path has lists), from random coefficients and states, holds
    and looks for separation: the same outcome, length, end, coefficients, proof sums and
    proven intervals, bit for bit; then StickingTaylor.step (compiled where it can be) against
    a pure stepper, root searches included."""
    from iceimpact.solvers.search import taylor
    if taylor.KERNELS is None:
        pytest.skip("numba is not installed (or ICEIMPACT_PURE is set): nothing compiled")
    rng = np.random.default_rng(11)
    outcomes = set()
    ends = set()
    for _ in range(400):
        args, kwargs, y = _random_stepper(rng)
        compiled = StickingTaylor(*args, **kwargs)
        pure = _pure_stepper(monkeypatch, *args, **kwargs)
        lo = rng.uniform(0.0, 10.0)
        until = math.inf if rng.random() < 0.7 else lo + rng.uniform(0.0, 2.0) * args[-1] / 20
        look = bool(rng.random() < 0.8)
        got = compiled._ordinary(lo, y, until, look)
        with monkeypatch.context() as patch:
            patch.setattr(taylor, "KERNELS", None)
            want = pure._ordinary(lo, y, until, look)
        assert tuple(float(w) for w in got) == tuple(float(w) for w in want)
        outcomes.add(got[0])
        if got[0] == taylor.NO_STEP:
            continue
        np.testing.assert_array_equal(compiled._work.table, pure._work.table, strict=True)
        rows = 2 if look else 1
        np.testing.assert_array_equal(compiled._work.sums[:, :rows], pure._work.sums[:, :rows])
        np.testing.assert_array_equal(compiled._work.proven[:, :rows],
                                      pure._work.proven[:, :rows])
        step = compiled.step(lo, y, until, look)
        with monkeypatch.context() as patch:
            patch.setattr(taylor, "KERNELS", None)
            want_step = pure.step(lo, y, until, look)
        assert (step.hi, step.h, step.end, step.y_hi) == \
            (want_step.hi, want_step.h, want_step.end, want_step.y_hi)
        np.testing.assert_array_equal(step.table, want_step.table)
        ends.add(step.end)
    # the cases met: ordinary steps, possible roots, flips and separations among them
    assert {taylor.NO_ROOT, taylor.MAYBE_ROOT} <= outcomes
    assert {StepEnd.LENGTH, StepEnd.FLIP, StepEnd.SEPARATION} <= ends


def test_the_pairwise_sum_is_numpys():
    """pairwise_sum, over floats (a row) and over arrays (the rows at once): numpy's add.reduce
    along a row, bit for bit, for 16 to 128 terms of mixed signs and scales (-0.0 sums too)."""
    from iceimpact.solvers.search.taylor_series import pairwise_sum
    rng = np.random.default_rng(5)
    for n in (16, 23, 37, 64, 101, 128):
        rows = rng.normal(size=(50, n)) * 10.0 ** rng.integers(-12, 12, (50, n))
        want = rows.sum(axis=1)
        partial = np.empty((8, 50))
        got = pairwise_sum(rows.T, partial)
        np.testing.assert_array_equal(got, want)
        assert [float(pairwise_sum(row, np.empty(8))) for row in rows] == want.tolist()
    assert math.copysign(1.0, pairwise_sum(np.full(37, -0.0), np.empty(8))) == 1.0


def _steps(seg: QuadraticStick) -> list:
    return [(s.lo, s.y_lo, s.h, s.hi, s.end, s.y_hi, s.table.tobytes()) for s in seg.steps]


@pytest.mark.parametrize("name", list(CASES))
def test_compiled_runs_of_steps_equal_the_pure_steps(name, monkeypatch):
    """QuadraticStick with its runs of ordinary steps made in one compiled call
    (StickingTaylor.run) against the same segment stepped one step at a time by the pure
    functions (taylor.KERNELS off): the same steps and separation, bit for bit, a hold
    included."""
    from iceimpact.solvers.search import taylor
    if taylor.KERNELS is None:
        pytest.skip("numba is not installed (or ICEIMPACT_PURE is set): nothing compiled")
    make, t_end = CASES[name]
    scene, x0, v0 = make()
    for start in (0.0, 0.3 * t_end):
        runs = []
        original = StickingTaylor.run

        def counted(self, *args, original=original, runs=runs):
            steps = original(self, *args)
            runs.append(len(steps))
            return steps
        with monkeypatch.context() as patch:
            patch.setattr(StickingTaylor, "run", counted)
            compiled = QuadraticStick(EventSolver(scene).context, 0.0, x0, v0, scene.flow_u, start)
            event = compiled.next_event(t_end)
        with monkeypatch.context() as patch:
            patch.setattr(taylor, "KERNELS", None)
            pure = QuadraticStick(EventSolver(scene).context, 0.0, x0, v0, scene.flow_u, start)
            assert pure.next_event(t_end) == event
        assert _steps(compiled) == _steps(pure)
        if name in ("figure18", "lockin_A2"):  # long phases: runs of many steps in one call
            assert max(runs) > 10


def test_a_step_off_the_compiled_path_is_taken_in_python():
    """A step the compiled kernels hand back (a step beyond 2^28 s, scaled by ldexp; its
    length in logarithms: a structure with a period of 1e67 s, as in
    test_search_regressions) is taken by the pure function: the same step as a pure
    stepper's."""
    from iceimpact.solvers.search import taylor
    if taylor.KERNELS is None:
        pytest.skip("numba is not installed (or ICEIMPACT_PURE is set): nothing compiled")
    args = (2.8e8, 0.0, 6.6e-125, 1e-14, 0.0, 11.0)
    stepper = StickingTaylor(*args, max_step=1.3e67)
    y = (-0.69, 1e-37, 0.0)
    with pytest.raises(taylor.HandBack):
        taylor.KERNELS.ordinary_step(0.0, *y, 1.0, True, 0.0, 1e-14, 0.0, 0.0, 6.6e-125, 11.0,
                                     1.3e67, *stepper._constants, *stepper._work.arrays(), 0.0)
    step = stepper.step(0.0, y, 1.0, True)
    pure = StickingTaylor(*args, max_step=1.3e67)
    pure._work = taylor._Work(False)
    pure._constants = (pure._constants[0].tolist(), taylor._RECIPROCAL_LIST,
                       taylor._EXPONENT_LIST)
    outcome, h, theta_end = taylor.ordinary_step(0.0, *y, 1.0, True, 0.0, 1e-14, 0.0, 0.0,
                                                 6.6e-125, 11.0, 1.3e67, *pure._constants,
                                                 *pure._work.arrays(), 0.0)
    assert step.h == h and np.array_equal(step.table, pure._work.table[:3].T)
    assert stepper.run(0.0, y, 0.0, 1.0) == []  # (the run stops before it)
