"""Hostile input, faults and misuse: a contact that pulls, accepted scenes that hang, and fuzzing
of the entry points that take outside data (scene files, CLI arguments). docs/robustness.md."""

from __future__ import annotations

import contextlib
import io
import json
import math
import random

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq

from iceimpact import ParameterError, Scene, Simulator, load_scene
from iceimpact.cli import main as cli_main
from iceimpact.fmi.adapter import FmuModel
from iceimpact.limits import (
    DRAG_RATE_MAX,
    OMEGA_MAX_EXACT,
    OMEGA_MAX_ODE,
    STICKING_RATE,
    TAYLOR_RATE_MAX,
    TIME_RESOLUTION,
)
from iceimpact.physics.ice import LinearDrag, QuadraticDrag
from iceimpact.physics.structure import Oscillator
from iceimpact.solvers.base import GAP_ROUNDING
from iceimpact.solvers.contact_rules import CHATTER_FRACTION
from iceimpact.solvers.exact import Flight, LinearStick
from iceimpact.solvers.rootfind import RootSearch
from scenes import ELASTIC_CHATTER

# --- a contact that pulls ---------------------------------------------------------------------

#: the ice resting on the structure (Figure 2 scene otherwise)
RESTING = {"structure_x0": 0.0, "ice_z0": 0.0, "ice_v0": 0.0}


def _toggled(i: int) -> float:
    """+0.1 m/s, reversed one communication step in four."""
    return -0.1 if i % 4 == 3 else 0.1


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
            r = sim.advance(h, _toggled(i))
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
            fmu.set("flow.u", _toggled(i))
            assert fmu.do_step(t, 5e-4)
            t += 5e-4
            assert fmu.get("contact.impulse") >= 0.0
            assert fmu.get("contact.force") >= 0.0
        assert not logs


# --- accepted scenes that hang: the limits ------------------------------------------------------

def test_the_limits_follow_from_the_numerics():
    # the chatter time stays above the root search's time resolution up to t = 1e6 s
    assert math.isclose(2.0 * math.pi * CHATTER_FRACTION / OMEGA_MAX_EXACT,
                        TIME_RESOLUTION * 1e6)


@pytest.mark.parametrize("method, k", [(1, 1e40), (3, 1e40), (1, 1600 * 1e8 ** 2),
                                       (3, 1600 * 2e4 ** 2)])
def test_a_structure_too_stiff_to_resolve_is_refused(method, k):
    scene = dict(structure_k=k, ice_z0=-0.01, ice_v0=0.0, flow_u=0.0, solver_method=method)
    with pytest.raises(ParameterError, match=r"omega_n <= .* rad/s with solver.method"):
        Scene(**scene)
    Scene(**{**scene, "solver_method": 2})  # method 2's grid has no such limit


@pytest.mark.parametrize("method", [1, 3])
def test_the_stiffest_structure_accepted_runs_in_bounded_time(method):
    """Just inside the limit, the ice in contact moving towards the structure (an impact at
    t = 0, then the structure rings): 20 steps of 1 ms finish quickly and soundly."""
    omega = 0.99 * (OMEGA_MAX_EXACT if method == 1 else OMEGA_MAX_ODE)
    sim = Simulator(Scene(structure_k=1600 * omega ** 2, structure_x0=0.0, ice_z0=0.0,
                          ice_v0=0.01, flow_u=0.0, solver_method=method))
    for _ in range(20):
        r = sim.advance(1e-3)
        assert r.gap >= 0.0 and r.impulse >= 0.0 and math.isfinite(r.x)
    assert sim.impact_count >= 1


@pytest.mark.parametrize("method, limit", [(1, "1.6e\\+06"), (3, "4.8e\\+05")])
def test_a_drag_too_stiff_to_integrate_is_refused(method, limit):
    # method 3's explicit integrators (the default DOP853) at ODE_EXPLICIT_RATE_MAX
    with pytest.raises(ParameterError, match=rf"flow.u.* speed <= {limit} m/s with quadratic"):
        Scene(drag_model=2, flow_u=1e12, solver_method=method)
    # mid-run: the step is refused and changes nothing
    sim = Simulator(Scene(drag_model=2, solver_method=method))
    sim.advance(1e-3)
    before = sim.save()
    with pytest.raises(ParameterError,
                       match=r"flow.u = 1000000000000.0 is not allowed: \|flow.u\| <= "):
        sim.advance(1e-3, 1e12)
    assert sim.save() == before
    Scene(drag_model=1, flow_u=1e12, solver_method=1)  # linear drag: closed forms


def test_a_stiff_linear_drag_is_refused_for_method_3():
    with pytest.raises(ParameterError, match=r"B \* drag.v_lin / ice.M"):
        Scene(ice_M=1e-6, solver_method=3)
    Scene(ice_M=1e-6, solver_method=1)


def test_the_drag_rate_limit_through_the_fmu():
    logs: list[str] = []
    fmu = FmuModel(lambda status, text: logs.append(text))
    fmu.set("drag.model", 2)
    assert fmu.initialize()
    assert fmu.do_step(0.0, 1e-3)
    x = fmu.get("structure.x")
    fmu.set("flow.u", 1e12)
    assert not fmu.do_step(1e-3, 1e-3)  # fmi2Discard, nothing changed
    assert "flow.u = 1000000000000.0 is not allowed" in logs[-1] and "1/s" in logs[-1]
    assert fmu.get("structure.x") == x
    fmu.set("flow.u", 0.1)
    assert fmu.do_step(1e-3, 1e-3)


@pytest.mark.parametrize("method", [1, 3])
def test_the_drag_rate_limit_at_the_limit_runs(method):
    """Just inside the drag-rate limit of each method: method 3 (LSODA) at DRAG_RATE_MAX on
    2 B u / M; method 1 at TAYLOR_RATE_MAX on its sticking phase's 2 B u / (m + M), the lower
    of its two limits for this scene."""
    if method == 1:
        u = 0.99 * TAYLOR_RATE_MAX * (1600.0 + 1600.0) / (2.0 * 499.5)
    else:
        u = 0.99 * DRAG_RATE_MAX * 1600.0 / (2.0 * 499.5)
    sim = Simulator(Scene(drag_model=2, flow_u=u, solver_method=method, solver_ode_method=3))
    for _ in range(5):
        r = sim.advance(1e-3)
        assert math.isfinite(r.x) and r.gap >= 0.0 and r.impulse >= 0.0


# --- fuzz: scene files ----------------------------------------------------------------------------

VALID_TOML = b"""\
"impact.e" = 0.5
[structure]
m = 1600.0
k = 1.0e6
c = 200.0
[ice]
M = 800.0
z0 = -0.01
[flow]
u = 0.1
"""


def _load_bytes(tmp_path, data: bytes):
    path = tmp_path / "scene.toml"
    path.write_bytes(data)
    return load_scene(path)


def _only_parameter_errors(tmp_path, data: bytes) -> None:
    try:
        _load_bytes(tmp_path, data)
    except ParameterError as exc:
        text = str(exc)
        assert " is not allowed: " in text and len(text) < 2000, text
    # any other exception fails the test


@settings(max_examples=150, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.binary(max_size=300))
def test_scene_file_random_bytes(tmp_path, data):
    _only_parameter_errors(tmp_path, data)


def test_scene_file_truncated_and_bit_flipped(tmp_path):
    assert _load_bytes(tmp_path, VALID_TOML).ice_M == 800.0
    for n in range(len(VALID_TOML)):
        _only_parameter_errors(tmp_path, VALID_TOML[:n])
    rng = random.Random(12)
    for _ in range(300):
        data = bytearray(VALID_TOML)
        for _ in range(rng.randint(1, 3)):
            i = rng.randrange(len(data))
            data[i] ^= 1 << rng.randrange(8)
        _only_parameter_errors(tmp_path, bytes(data))


@pytest.mark.parametrize("text, name", [
    ('"structure.k" = 1e400', "structure.k"),                # TOML overflow: inf in the file
    ('"structure.k" = ' + "9" * 5000, "scene file"),          # beyond Python's int parsing
    ('"structure.k" = ' + "9" * 400, "structure.k"),          # an integer no double holds
    ('"ice.M" = 1e308\n"ice.v0" = 1e300', "ice.M * ice.v0^2 / 2"),
    ('"structure.k" = 1e40', "sqrt(structure.k / structure.m)"),
    ('"flow.u" = 1e12\n"drag.model" = 2',
     "|flow.u| + |ice.v0| + 2 sqrt(structure.v0^2 + (omega_n structure.x0)^2)"),
    ('"ice.M" = 1.0\n"ice.M" = 2.0', "scene file"),           # duplicate key: TOML error
    ('"ice.M" = 1.0\n[ice]\nM = 2.0', "ice.M"),               # twice, two spellings
    ('"ice.M" = "heavy"', "ice.M"),
    ('"ice.M" = true', "ice.M"),
    ('"ice.M" = [1.0]', "ice.M"),
    ('"ice.M" = 1979-05-27', "ice.M"),
    ('"ice.M" = nan', "ice.M"),
    ('"ice.M" = -inf', "ice.M"),
    ('"drag.model" = 1.5', "drag.model"),
    ('"solver.method" = 99999999999999999999999', "solver.method"),
    ("[ice]\nM = { a = 1 }", "ice.M.a"),
    ('"ice.mass" = 1.0', "ice.mass"),
])
def test_scene_file_bad_values(tmp_path, text, name):
    with pytest.raises(ParameterError) as info:
        _load_bytes(tmp_path, text.encode())
    assert info.value.name == name
    assert " is not allowed: " in str(info.value) and len(str(info.value)) < 2000


# --- fuzz: CLI arguments ------------------------------------------------------------------

def _cli(argv: list[str]) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            status = cli_main(argv)
        except SystemExit as exc:
            status = exc.code
    return status, err.getvalue()


_VALUES = st.one_of(
    st.sampled_from(["nan", "inf", "-inf", "1e400", "-1e400", "0", "-0", "-1", "1e-400",
                     "9" * 5000, "", " ", "1e40", "1e12", "0x10", "1_000", "true", "=",
                     "1,5", "\x00", "１"]),
    st.text(max_size=12), st.floats(allow_nan=True, allow_infinity=True).map(repr))
_NAMES = st.one_of(st.sampled_from(["structure.k", "ice.M", "flow.u", "drag.model",
                                    "solver.method", "impact.e", "solver.dt", "ice.mass", "",
                                    " ice.M ", "structure"]), st.text(max_size=8))


@settings(max_examples=60, deadline=None, derandomize=True)
@given(name=_NAMES, value=_VALUES, option=st.sampled_from(["--set", "--t-end", "--dt"]))
def test_cli_bad_arguments_exit_2_with_a_message(name, value, option):
    arg = f"{name}={value}" if option == "--set" else value
    argv = ["simulate", option, arg, "--t-end", "1e-3", "--dt", "1e-3"]
    if option != "--set":
        argv = ["simulate", "--t-end", "1e-3", "--dt", "1e-3", option, arg]
    status, err = _cli(argv)
    if status == 0:  # a valid value: the run went through
        return
    assert status == 2, (argv, status, err)
    assert "error:" in err and "Traceback" not in err, err


def test_underflowing_scales_are_a_parameter_error_not_a_zero_division():
    """structure.k = structure.m = 1e-200 raised a bare ZeroDivisionError (sqrt(k m) = 0):
    a ParameterError naming the combination, in Python, through the CLI and through the FMU."""
    with pytest.raises(ParameterError, match=r"zeta\^2 = .* = inf is not allowed"):
        Scene(structure_k=1e-200, structure_m=1e-200)
    status, err = _cli(["simulate", "--set", "structure.k=1e-200", "--set", "structure.m=1e-200",
                        "--t-end", "1e-3", "--dt", "1e-3"])
    assert status == 2 and "zeta^2" in err and "Traceback" not in err
    logs: list[str] = []
    fmu = FmuModel(lambda status, text: logs.append(text))
    fmu.set("structure.k", 1e-200)
    fmu.set("structure.m", 1e-200)
    fmu.initialize()
    assert not fmu.do_step(0.0, 1e-3)
    assert any("zeta^2" in text for text in logs)


def test_cli_refuses_a_scene_it_cannot_run_in_bounded_time():
    status, err = _cli(["simulate", "--set", "structure.k=1e40", "--t-end", "1e-3",
                        "--dt", "1e-3"])
    assert status == 2 and "omega_n <=" in err and "Traceback" not in err


# --- faults the random search found (tools/random_search.py --scales --flows) -----------------

def test_a_stiff_structure_ringing_far_from_the_ice_costs_no_work_per_period():
    """Method 1, a stiff undamped structure (omega_n 1.3e7 rad/s) ringing with 0.6 m amplitude
    while the ice coasts towards the lowest point of its swing: the root search's Taylor steps
    (curvature bound omega_n^2 x amplitude) took a few evaluations per period, over 30 s of
    work per simulated second. The structure's envelope now proves the gap open until the ice
    can reach it. The impact time agrees with the closed form written out here
    (x = x0 cos(omega_n t), z = z0 + w0 t)."""
    omega, x0, z0, w0 = 1.3e7, -0.6, -0.65, 0.1
    sim = Simulator(Scene(structure_m=1600.0, structure_k=1600.0 * omega ** 2, structure_c=0.0,
                          structure_x0=x0, structure_v0=0.0, ice_M=1600.0, ice_Cd=0.0,
                          ice_z0=z0, ice_v0=w0, flow_u=0.1, impact_e=1.0, solver_method=1))
    while sim.t < 0.45 - 1e-12:
        r = sim.advance(0.05)
        assert r.gap > 0.0 and sim.impact_count == 0
    # a handful of search iterations, not one per fraction of each of 9e5 periods
    assert sim.solver.seg.search.iterations < 10
    sim.advance(0.1)
    assert sim.impact_count == 1

    def gap(t):
        return x0 * math.cos(omega * t) - (z0 + w0 * t)

    # the ice reaches the swing's lowest point x0 at t = 0.5 s; the impact is on the way down
    # to the first trough (t = 2 pi j / omega) after that
    trough = 2.0 * math.pi * math.ceil((x0 - z0) / w0 * omega / (2.0 * math.pi)) / omega
    exact = brentq(gap, trough - math.pi / omega, trough, xtol=1e-18, rtol=1e-15)
    assert abs(sim.impacts[0].t - exact) <= 1e-14


def _reversing(u: float, i: int) -> float:
    return u if i % 2 == 0 else -u


def test_a_flow_changing_at_every_step_costs_method_3_work_in_proportion_to_the_step():
    """Method 3 restarted a whole chunk (1 s here) at every flow change: with a flow reversing
    at every 0.1 ms step and a stiff damping (c/m = 2.5e4 1/s) a run of 50 ms did not finish in
    30 s. After a flow change the integration now spans the step, then doubles."""
    u = 0.92
    sim = Simulator(Scene(structure_m=0.0736, structure_c=1803.6, structure_k=33645.0,
                          structure_x0=-0.917, structure_v0=-0.84, ice_M=1.43e-5,
                          ice_Cd=0.0, ice_z0=-1.008, ice_v0=-0.84, impact_e=0.0,
                          drag_model=2, flow_u=-u, solver_method=3))
    sim.advance(1e-4)  # the scene's own flow: its first chunk of 1 s (~6e4 evaluations)
    before = sim.solver.nfev
    for i in range(1, 51):
        r = sim.advance(1e-4, _reversing(-u, i))
        assert r.gap >= 0.0 and math.isfinite(r.x)
    # a 1 s chunk of this stiff damping takes ~6e4 evaluations; a 0.1 ms step ~1e2
    assert sim.solver.nfev - before < 50 * 1000


@pytest.mark.parametrize("drag", [1, 2])
def test_method_3_follows_a_flow_changing_at_every_step(drag):
    """Figure 2 scene in flight, the ice 2 mm upstream closing at 10 mm/s, the flow reversed
    at every 1 ms step for 0.3 s, one impact on the way: method 3's states agree with method 1's
    (closed forms) to its tolerance at every step, and a snapshot taken inside a shortened span
    continues to the last bit."""
    exact = Simulator(Scene(drag_model=drag, ice_z0=-0.002, solver_method=1))
    ode = Simulator(Scene(drag_model=drag, ice_z0=-0.002, solver_method=3, solver_rtol=1e-10))
    for i in range(300):
        a, b = exact.advance(1e-3, _reversing(0.1, i)), ode.advance(1e-3, _reversing(0.1, i))
        for name in ("x", "v", "z", "w"):
            assert abs(getattr(a, name) - getattr(b, name)) <= 1e-6 * 0.01, (i, name, a, b)
    assert exact.impact_count == ode.impact_count >= 1
    saved = json.loads(json.dumps(ode.save()))
    inputs = [(7e-4, _reversing(0.1, i)) for i in range(20)] + [(0.05, 0.1)] * 10
    twin = Simulator.from_snapshot(saved)
    assert [twin.advance(h, u) for h, u in inputs] == [ode.advance(h, u) for h, u in inputs]


def test_the_rounding_closing_speed_rule_at_its_edges():
    """ContactRules.is_rounding writes its magnitudes without abs(): the same answer as
    |closing| <= 1e-12 (|v| + |w| + |u| + wn |x|) + 1e-300 for zeros of either sign, speeds at
    and just beyond the limit, infinities and NaN."""
    from itertools import product

    from iceimpact.solvers.contact_rules import EXACT_POLICY, ROUNDING_SPEED, ContactRules

    omega_n = 3.0
    rules = ContactRules(1.0, 2.0, omega_n, lambda *state: (0.0, 0.0), EXACT_POLICY)
    values = [0.0, -0.0, 2e-300, -2e-300, 0.5, -0.7, 3.0, math.inf, -math.inf, math.nan]
    checked = 0
    for x, v, w, u in product(values, repeat=4):
        limit = ROUNDING_SPEED * (abs(v) + abs(w) + abs(u) + omega_n * abs(x)) + 1e-300
        edges = [limit, math.nextafter(limit, math.inf)] if math.isfinite(limit) else [1.0]
        for closing in [0.0, -0.0, 1e-300, 1.0, math.inf, math.nan] + edges:
            for c in (closing, -closing):
                assert rules.is_rounding(c, x, v, w, u) == (abs(c) <= limit), (c, x, v, w, u)
                checked += 1
    assert checked > 100_000


@pytest.mark.parametrize("drag", [LinearDrag(1.0, 0.0), QuadraticDrag(1.0, 0.0),
                                  LinearDrag(1.0, 3.0), QuadraticDrag(1.0, 3.0)])
def test_the_ice_velocity_is_exact_at_the_anchor(drag):
    """w(0) = w0 to the last bit, and w = w0 at all times without drag, even when |w0| is far
    below |u|: u + (w0 - u) e^0 gave 0 for w0 = 1e-169, u = 0.1."""
    for w0 in (1e-169, -1.3e-169, 0.37, -2.0):
        assert drag.displacement_change(w0, 0.1, 0.0) == (0.0, w0)
        if drag.force(1.0, 0.0) == 0.0:  # no drag: the ice coasts
            assert drag.displacement_change(w0, 0.1, 7.0)[1] == w0


def test_bodies_at_rest_with_no_drag_and_a_toggled_flow_finish():
    """Method 1, both bodies in contact at speeds of 1e-169 m/s, no drag, the flow toggled:
    every flight from the contact saw the ice's velocity as 0 (the rounding above), an approach
    at rounding speed, and met a contact again at the same instant, without end (the first
    0.1 ms step did not finish in 30 s)."""
    v0 = -1.3342728836344646e-169
    sim = Simulator(Scene(structure_m=3.6256e-4, structure_c=0.0, structure_k=5.065e-7,
                          structure_x0=0.0, structure_v0=v0, ice_M=6.6e-8, ice_Cd=0.0,
                          ice_z0=0.0, ice_v0=v0, impact_e=0.0, drag_model=1, flow_u=0.0,
                          solver_method=1))
    for i in range(100):
        r = sim.advance(1e-4, _toggled(i))
        assert r.gap >= 0.0 and r.impulse >= 0.0 and abs(r.w) <= abs(v0)


def test_a_decayed_velocity_keeps_its_precision():
    """The flight's closed form recovered C(t) as (C - 1) + 1, an error of one ulp of 1: the
    velocity of a strongly over-damped structure (zeta = 46) carried eps |v0| long after it had
    decayed below that, and the root search, seeing that noise as a slope, crawled along a gap
    of 1e-24 m (0.01 s did not finish in 30 s). Checked against the slow exponential of the
    over-damped response, v = v0 s1 e^{s1 t} / (s1 - s2) once the fast one has died out."""
    m, c, k, v0 = 0.1326, 5.502e6, 2.658e10, 0.558
    osc = Oscillator(m, c, k)
    sigma, wo = c / (2.0 * m), math.sqrt((c / (2.0 * m)) ** 2 - k / m)
    slow, fast = -(k / m) / (sigma + wo), -(sigma + wo)
    for t in (1e-3, 7.6e-3, 3e-2):
        dx, v = osc.displacement_change(0.0, v0, t)
        exact = v0 * slow * math.exp(slow * t) / (slow - fast)
        assert v == pytest.approx(exact, rel=1e-9)
        assert dx == pytest.approx(v0 * math.exp(slow * t) / (slow - fast), rel=1e-9)
    sim = Simulator(Scene(structure_m=m, structure_c=c, structure_k=k, structure_x0=0.0,
                          structure_v0=v0, ice_M=4.3e-3, ice_Cd=0.0, ice_z0=0.0, ice_v0=0.0,
                          impact_e=0.0, flow_u=0.0, solver_method=1))
    sim.advance(0.01)
    assert sim.solver.seg.search.iterations < 1000 and sim.solver.state.gap > 0.0


def test_a_light_floe_struck_by_a_fast_structure_is_refused():
    """Quadratic drag with a light floe of a large area (B/M = 1.7e10 1/m) resting on a
    structure that moves at 0.45 m/s: the impact gives the ice a speed whose drag rate is 8e9
    1/s and the quadratic-drag sticking integration did not finish. The drag-rate rule now
    counts the speed an impact can give the ice (up to twice the structure's speed bound)."""
    scene = dict(structure_m=1e-5, structure_c=0.0, structure_k=11.68, structure_x0=0.86,
                 structure_v0=0.453, ice_M=1e-5, ice_A=261.6, ice_Cd=1.28, ice_z0=0.86,
                 ice_v0=0.0, impact_e=0.0, drag_model=2, flow_u=-6.6e-6)
    for method in (1, 3):
        with pytest.raises(ParameterError, match=r"structure.x0\)\^2\) = .* speed <= "):
            Scene(**scene, solver_method=method)
    Scene(**scene, solver_method=2, solver_dt=1e-5)  # method 2: its own rule, on solver.dt


def test_method_3_repeated_events_do_not_hold_a_pulling_contact():
    """Method 3 closes events repeating at one instant (integration noise at a loose tolerance)
    with a plastic contact and a pause of the event search. It held the bodies together
    whatever the sign of the contact force: in the Figure 2 scene with e = 0 at rtol 1e-9 it
    held them against a pull of 6 N at t = 8.276 s and lost the bounce that method 1 finds at
    8.284 s. While the force pulls, the bodies now fly apart instead: the impacts over 12 s
    are method 1's, to the tolerance."""
    def impacts(method, rtol):
        sim = Simulator(Scene(impact_e=0.0, solver_method=method, solver_rtol=rtol))
        while sim.t < 12.0 - 1e-9:
            r = sim.advance(0.01)
            assert r.impulse >= 0.0 and r.gap >= 0.0
        return [i.t for i in sim.impacts]

    exact, ode = impacts(1, 1e-8), impacts(3, 1e-9)
    assert len(exact) == len(ode) == 8
    assert max(abs(a - b) for a, b in zip(exact, ode, strict=True)) < 1e-4


def test_method_3_lets_a_fast_parting_ice_fly():
    """The ice starting on the structure and leaving at 35 m/s against a strong quadratic drag
    (lam chatter_time far above the parting momentum): method 3's slow-parting rule took it for
    integration noise and stuck the bodies with a plastic entry, an impulse of -17 N.s that
    pulled the ice back. Only a parting within the velocities' tolerance is noise now: the ice
    flies as it does with method 1 (closed forms). (The search's area was 9.446 m^2; 9.4 keeps
    the sticking drag rate within method 1's TAYLOR_RATE_MAX, which the reference run needs.)"""
    scene = dict(structure_m=1.0, structure_c=0.0, structure_k=22088.8, structure_x0=0.0,
                 structure_v0=0.0, ice_M=1.0, ice_A=9.4, ice_Cd=0.61, ice_z0=0.0,
                 ice_v0=-34.76, impact_e=0.0, drag_model=2, flow_u=0.1)
    exact = Simulator(Scene(**scene, solver_method=1))
    ode = Simulator(Scene(**scene, solver_method=3))
    for _ in range(5):
        a, b = exact.advance(1e-3), ode.advance(1e-3)
        assert b.impulse >= 0.0 and not b.sticking
        assert b.z == pytest.approx(a.z, rel=1e-6) and b.w == pytest.approx(a.w, rel=1e-6)
    assert ode.solver.state.z < -1e-3  # the ice is upstream, on its way back


def test_method_3_bodies_parting_under_noise_still_meet_again():
    """A 48.6 t floe at 1903 m/s strikes a 31.6 kg structure (e = 0): the bodies move together,
    the drag pulls them apart by 0.2 N at the start while the spring brings them together
    microseconds later. Method 3 met the gap event again and again at the instant of the impact
    (integration noise); a first sign-aware closure let the bodies fly with the gap event
    paused and the ice went 2e-7 m through the structure. The gap event of that flight is now
    set just below the noise of the positions, so the contact is met again: the motion is
    method 1's (closed forms) to the tolerance and the gap stays within it."""
    scene = dict(structure_m=31.62, structure_c=0.0, structure_k=21626.0, structure_x0=0.0,
                 structure_v0=0.961, ice_M=48641.0, ice_A=0.347, ice_Cd=0.001,
                 ice_z0=0.0, ice_v0=1903.0, impact_e=0.0, drag_model=1, flow_u=0.1)
    exact = Simulator(Scene(**scene, solver_method=1))
    ode = Simulator(Scene(**scene, solver_method=3))
    for _ in range(200):
        a, b = exact.advance(1e-4), ode.advance(1e-4)
        assert ode.solver.state.gap >= -1e-10 and b.impulse >= 0.0
        assert b.x == pytest.approx(a.x, rel=1e-6, abs=1e-9)


def test_sticking_far_from_its_equilibrium_keeps_the_impulse_sound():
    """Method 1, linear drag: a soft structure (k = 1.2e-4 N/m) pressed by a strong drag
    (b = 8.1e4 kg/s) sticks towards an equilibrium b u / k = 6.9e7 m away. Positions about it
    carry its rounding (1e-7 m) and b (xb - xa) turned that into contact impulses of +-0.1 N.s,
    some tensile. The displacement increments now come from the exponents of the over-damped
    motion: each step's impulse equals the structure's momentum balance
    m dv + c dx + k x dt (the force on the structure is its inertia, damping and spring)."""
    m, k = 1.0, 1.1779e-4
    sim = Simulator(Scene(structure_m=m, structure_c=0.0, structure_k=k, structure_x0=0.0,
                          structure_v0=0.0, ice_M=393.5, ice_A=812.19, ice_Cd=2.0, ice_z0=0.0,
                          ice_v0=0.0, impact_e=0.0, drag_model=1, flow_u=0.1,
                          solver_method=1))
    v_before, x_before = 0.0, 0.0
    for _ in range(8):
        r = sim.advance(1e-3)
        assert r.sticking and r.impulse >= 0.0
        balance = m * (r.v - v_before) + k * 0.5 * (r.x + x_before) * 1e-3
        assert r.impulse == pytest.approx(balance, rel=1e-6, abs=1e-12)
        v_before, x_before = r.v, r.x


@pytest.mark.parametrize("drag", [1, 2])
def test_a_flow_change_right_after_an_impact_at_t0_keeps_the_momentum(drag):
    """Method 3, the structure striking the ice at t = 0 (e = 0) and the flow changed at the
    first step: the re-anchor took the state last reported (before the impact) instead of the
    segment's, gave the ice the structure's pre-impact velocity and created momentum (energy
    grew from 1.3e-4 J to 0.37 J at u = 0). It now continues from the plastic impact, as
    method 1 does."""
    scene = dict(structure_m=2.626e-4, structure_c=0.0, structure_k=2.626e-4, structure_x0=0.09,
                 structure_v0=-0.98, ice_M=0.766, ice_Cd=0.0, ice_z0=0.09, ice_v0=0.0,
                 impact_e=0.0, drag_model=drag, flow_u=81.4)
    momentum = scene["structure_m"] * scene["structure_v0"]
    runs = []
    for method in (1, 3):
        sim = Simulator(Scene(**scene, solver_method=method))
        sim.advance(1e-6, 0.0)  # the spring's impulse over 1 us is 2e-11 N.s
        s = sim.solver.state
        assert scene["structure_m"] * s.v + scene["ice_M"] * s.w == pytest.approx(momentum,
                                                                                  rel=1e-6)
        sim.advance(1.0, 0.0)
        runs.append(sim.solver.state)
    exact, ode = runs
    assert ode.v == pytest.approx(exact.v, rel=1e-6) and ode.x == pytest.approx(exact.x, rel=1e-6)


def test_the_over_damped_amplitude_bound_is_sound_and_tight():
    """The bound on a free response's future |y| that the root searches use: over-damped it is
    now |A| + |B| of its two exponentials where that is tighter than the energy bound (by
    sigma / omega_n). Checked against a scipy integration of y'' + 2 sigma y' + omega_n^2 y = 0:
    never below the largest |y| ahead, and within a factor 2 of it."""
    from scipy.integrate import solve_ivp
    osc = Oscillator(2.2e-5, 4993.0, 1.14e-5)  # sigma 1.1e8 1/s, omega_n 0.72 rad/s
    two_sigma, omega2 = osc.damping / osc.mass, osc.stiffness / osc.mass
    for y0, v0 in ((1.0, 0.0), (0.0, 1.0), (1.0, -2e8), (-3.0, 5e7), (1e-3, -1e-3)):
        bound = osc.amplitude_bound(y0, v0)
        sol = solve_ivp(lambda t, s: [s[1], -two_sigma * s[1] - omega2 * s[0]], (0.0, 1e-6),
                        [y0, v0], method="Radau", rtol=1e-10, atol=1e-14, dense_output=True)
        peak = max(abs(y0), float(np.max(np.abs(sol.sol(np.linspace(0.0, 1e-6, 20001))[0]))))
        assert peak <= bound * (1 + 1e-6) and bound <= 2.0 * peak + 1e-12, (y0, v0, peak, bound)
        assert bound < math.sqrt(y0 * y0 + v0 * v0 / omega2) or v0 == 0.0


def test_a_light_floe_sticking_under_a_strong_linear_drag_finishes():
    """Method 1: a 10 g floe under a linear drag of b/M = 4.9e8 1/s sticks to a 11 g structure:
    the search for its separation bounded the contact force's derivatives by the energy bound,
    3e8 times too loose, and crawled at 1e-13 s steps."""
    sim = Simulator(Scene(structure_m=1.14e-5, structure_c=2.28e-5, structure_k=1.14e-5,
                          structure_x0=0.0, structure_v0=0.124, ice_M=1.02e-5, ice_A=6.82,
                          ice_Cd=1.5, ice_z0=0.0, ice_v0=0.0, impact_e=1.0, drag_model=1,
                          drag_v_lin=0.977, flow_u=0.1, solver_method=1))
    for _ in range(3):
        r = sim.advance(0.37)
        assert r.gap >= 0.0 and r.impulse >= 0.0
    assert sim.solver.seg.search.iterations < 100_000


def test_method_3_work_per_impact_follows_the_impact_not_the_chunk():
    """Method 3, a stiff undamped structure (omega_n 3e3 rad/s) bouncing the ice every ~0.4 ms:
    each impact started a segment integrated a whole chunk (1 s, ~1e4 periods) ahead, 4.6e5
    evaluations for 10 ms. A segment's first call now spans one period, then doubles."""
    sim = Simulator(Scene(structure_m=1.0, structure_c=0.0, structure_k=9.171e6,
                          structure_x0=0.0, structure_v0=0.0, ice_M=1.0, ice_A=1.023,
                          ice_Cd=0.2168, ice_z0=-1e-5, ice_v0=0.0, impact_e=1.0, drag_model=1,
                          drag_v_lin=0.9937, flow_u=3.48, solver_method=3))
    for i in range(100):
        r = sim.advance(1e-4, -3.48 if i % 4 == 3 else 3.48)
        assert r.gap >= 0.0 and r.impulse >= 0.0
    assert sim.impact_count >= 10
    assert sim.solver.nfev < 50_000


def test_a_structure_damped_too_stiffly_to_integrate_is_refused_for_method_3():
    """An over-damped structure relaxes at up to c / m: for method 3's explicit integrators a
    rate like the drag's, held to the same limit."""
    with pytest.raises(ParameterError,
                       match=r"structure.c / structure.m = 2000000.0 is not allowed: <= 1e\+06"):
        Scene(structure_c=2e6 * 1600.0, solver_method=3, solver_ode_method=3)
    Scene(structure_c=2e6 * 1600.0, solver_method=1)
    Scene(structure_c=0.9e6 * 1600.0, solver_method=3, solver_ode_method=3)


def test_a_structure_too_stiff_for_the_quadratic_sticking_steps_is_refused_for_method_1():
    """The random search's stiff, over-damped scene (omega of the bodies together 1.1e7 rad/s,
    c / (m + M) = 3.9e8 1/s) under quadratic drag ran without end in method 1's sticking phase
    (explicit Taylor steps of about 1 / rate): refused up front, naming the combination, its
    value and the limit; the same scene with linear drag (closed-form sticking) is accepted, and
    a rate just below the limit is accepted too."""
    stiff = dict(structure_m=232755831.8212012, structure_c=1.7993742487458515e+17,
                 structure_k=5.559221199183276e+22, ice_M=232755831.8212012, ice_A=1.0,
                 ice_Cd=0.3426254990962821, drag_v_lin=1.0, impact_e=0.5,
                 structure_x0=0.0, ice_z0=-0.01, flow_u=0.1)
    with pytest.raises(ParameterError) as err:
        Scene(drag_model=2, **stiff)
    message = str(err.value)
    assert message.startswith(STICKING_RATE)
    assert f"{TAYLOR_RATE_MAX:g} 1/s" in message and "drag.model = 1" in message
    Scene(drag_model=1, **stiff)
    Scene(drag_model=2, solver_method=2, **stiff)
    total = Scene().structure_m + Scene().ice_M
    Scene(drag_model=2, structure_c=0.0, structure_k=total * (0.99 * TAYLOR_RATE_MAX) ** 2)
    with pytest.raises(ParameterError):
        Scene(drag_model=2, structure_c=0.0, structure_k=total * (1.01 * TAYLOR_RATE_MAX) ** 2)


#: 1 kg floe on a 1 kg structure (m + M = 2 kg), quadratic drag at u = 1 m/s (method 1)
_PAIR = dict(structure_m=1.0, ice_M=1.0, ice_Cd=1.0, structure_x0=0.0, structure_v0=0.0,
             ice_z0=0.0, ice_v0=0.0, drag_model=2, flow_u=1.0, solver_method=1)


def _pair(omega_n: float, zeta: float, drag_rate: float, **fields) -> dict:
    """_PAIR with the structure's omega_n (rad/s) and zeta, and 2 B u / M = drag_rate (1/s)."""
    k = omega_n ** 2
    return {**_PAIR, "structure_k": k, "structure_c": 2.0 * zeta * math.sqrt(k),
            "ice_A": drag_rate / (2.0 * 499.5), **fields}


def test_sticking_phases_too_slow_for_the_taylor_steps_are_refused_for_method_1():
    """Method 1's quadratic-drag sticking phase takes Taylor steps of about 1 / rate (0.1 to
    0.3 steps x rate per simulated second), up to ~2e-5 s of CPU x rate per simulated second
    (tools/taylor_rate_cost.py). Under the former limit of 1e6 1/s the search found an
    over-damped structure (omega_n 1.6e4 rad/s, zeta 6.1) under a drag rate 2 B u / M of
    2.9e5 1/s sticking at ~3.2 s of CPU per simulated second, and stiff pairs (sqrt(k / (m + M))
    of 3.7e5-5.4e5 rad/s) at 4.5-10 s. The rule now holds each rate of the sticking equation,
    the drag's 2 (B + B_s) speed / (m + M) included, to TAYLOR_RATE_MAX = 1e5 1/s, up front and
    for each new flow.u, naming the rates, their values and the limit."""
    assert TAYLOR_RATE_MAX == 1e5
    # the over-damped scene: sqrt(k / (m + M)) = 1.1e4, c / (m + M) = 9.8e4, drag 1.45e5 1/s
    with pytest.raises(ParameterError) as err:
        Scene(**_pair(1.6e4, 6.1, 2.9e5))
    message = str(err.value)
    assert message.startswith(f"{STICKING_RATE} = 145000")
    assert "sqrt(structure.k / (m + M)) = 1.13e+04 rad/s" in message
    assert "structure.c / (m + M) = 9.76e+04 1/s" in message
    assert "2 (B + B_s) speed / (m + M) = 1.45e+05 1/s" in message
    assert "<= 100000 1/s with quadratic drag and solver.method = 1" in message
    Scene(**_pair(1.6e4, 6.1, 1.9e5))  # drag 9.5e4 1/s: accepted
    Scene(**_pair(1.6e4, 6.1, 2.9e5, drag_model=1))  # linear drag: closed-form sticking
    # a stiff pair: sqrt(k / (m + M)) = 3.7e5 rad/s
    with pytest.raises(ParameterError, match=r"= 370000.0000000\d* is not allowed: <= 100000"):
        Scene(**_pair(3.7e5 * math.sqrt(2.0), 0.0, 1e3))
    with pytest.raises(ParameterError, match=r"structure.c / \(m \+ M\) = 1.2e\+05 1/s"):
        Scene(**_pair(1e4, 12.0, 1e3))  # over-damped: c / (m + M) = 1.2e5 1/s
    Scene(**_pair(0.99e5 * math.sqrt(2.0), 0.0, 1e3))
    # the drag on the structure counts as well: B_s doubles the rate of a drag just inside
    Scene(**_pair(1e2, 0.0, 1.8e5))
    with pytest.raises(ParameterError, match=r"2 \(B \+ B_s\) speed / \(m \+ M\) = 1.8e\+05"):
        Scene(**_pair(1e2, 0.0, 1.8e5, structure_Cd=1.0,
                      structure_A=1.8e5 / (2.0 * 499.5)))
    # mid-run: a flow whose sticking drag rate exceeds the limit refuses that step only
    sim = Simulator(Scene(drag_model=2))
    sim.advance(1e-3)
    before = sim.save()
    u_max = TAYLOR_RATE_MAX * 3200.0 / (2.0 * 499.5)  # 3.2e5 m/s, below the 1.6e6 of 2 B u / M
    with pytest.raises(ParameterError, match=r"flow.u = .* is not allowed: \|flow.u\| <= "
                                             r"3.2e\+05 m/s .* 2 \(B \+ B_s\) \|flow.u\| / "
                                             r"\(m \+ M\) = 1.01e\+05 1/s"):
        sim.advance(1e-3, 1.01 * u_max)
    assert sim.save() == before
    sim.advance(1e-3, 0.99 * u_max)


@pytest.mark.parametrize("kind", ["stiff", "over-damped", "stiff drag"])
def test_taylor_sticking_steps_per_simulated_second_are_proportional_to_the_rate(kind):
    """Just inside TAYLOR_RATE_MAX, the scenes of tools/taylor_rate_cost.py (a 1 kg floe stuck
    from rest on a 9 kg structure whose sqrt(k / (m + M)), c / (m + M) or sticking drag rate is
    the given rate), the flow switched at every 1 ms step as there (1 and 0.5 m/s): the Taylor
    steps per simulated second stay below 0.6 x rate (measured 0.1-0.3 at 1e5 1/s), the work
    the limit was derived from; independent of CPU speed."""
    from iceimpact.solvers import taylor
    from taylor_rate_cost import LOW_FLOW, scene

    calls = [0]
    original = taylor.StickingTaylor.step

    def counted(self, *args, **kwargs):
        calls[0] += 1
        return original(self, *args, **kwargs)

    rate = 0.99 * TAYLOR_RATE_MAX
    taylor.StickingTaylor.step = counted
    try:
        sim = Simulator(scene(kind, rate))
        for i in range(20):
            r = sim.advance(1e-3, 1.0 if i % 2 == 0 else LOW_FLOW[kind])
            assert r.gap >= 0.0 and r.impulse >= 0.0 and math.isfinite(r.x)
    finally:
        taylor.StickingTaylor.step = original
    assert sim.sticking and sim.sticking_since == 0.0
    assert 0.0 < calls[0] <= 0.6 * rate * sim.t
    # just outside: refused (the stiff drag by the drag rule 2 B u / M <= 1e6 1/s as well)
    with pytest.raises(ParameterError, match=r"is not allowed: (<= 100000 1/s|speed <=)"):
        scene(kind, 1.01 * TAYLOR_RATE_MAX)


def test_a_sticking_separation_at_denormal_scales_is_located():
    """A light, stiff pair sticking at positions of 1e-178 m with no drag (a random search
    scene): the separation's root lies at a normalised time so close to 0 that brentq's default
    100 iterations did not reach it (RuntimeError). The Taylor step's root search now allows the
    bisection depth those scales need, and the run is sound."""
    scene = Scene(structure_m=1.2811449567924302e-06, structure_c=0.8540966378616202,
                  structure_k=1281144.9567924303, structure_x0=3.457191159007816e-178,
                  structure_v0=1.1857442825908975e-249, ice_M=0.0003156398940550749,
                  ice_A=0.005081541681607078, ice_Cd=0.0, ice_z0=3.457191159007816e-178,
                  ice_v0=0.0, impact_e=1.0, drag_model=2, drag_v_lin=0.00491631729782529,
                  flow_u=0.0)
    sim = Simulator(scene)
    for _ in range(3):
        report = sim.advance(10.0)
        values = [report.x, report.v, report.z, report.w, report.gap, report.impulse]
        assert all(math.isfinite(value) for value in values)
        assert report.gap >= 0.0 and report.impulse >= 0.0


# --- exact tangent ringing (method 1) -----------------------------------------------------------

#: omega_n = 4.1e7 rad/s, released from rest at -0.16 m, the ice at rest exactly at the lowest
#: point of the swing, no drag
TANGENT_OMEGA, TANGENT_X0 = 4.1e7, -0.16


def _tangent_ringing(u: float, v0: float = 0.0) -> Simulator:
    return Simulator(Scene(structure_m=1600.0, structure_k=1600.0 * TANGENT_OMEGA ** 2,
                           structure_c=0.0, structure_x0=TANGENT_X0, structure_v0=v0,
                           ice_M=1600.0, ice_Cd=0.0, ice_z0=TANGENT_X0, ice_v0=0.0, flow_u=u,
                           impact_e=1.0, solver_method=1))


@pytest.mark.parametrize("u", [0.0, 0.1])
def test_an_exact_tangent_ringing_is_no_impact(u):
    """The structure grazes the ice once a period (6.5e6 times a second) with no closing speed:
    the exact motion is x = x0 cos(omega_n t) with the ice at rest at x0 and never struck. The
    root search located a touch at the first graze to its time resolution and took the
    structure's speed there (0.33 m/s, curvature x resolution) for a closing speed, kicking the
    ice; each graze it met cost root-search work. The envelope now proves the whole future free
    of impacts at once: one search iteration for the run, whatever the number of grazes. Without
    drag the flow does not move the ice (u = 0.1: its speed bound is its own velocity, 0)."""
    sim = _tangent_ringing(u)
    k, m = sim.scene.structure_k, sim.scene.structure_m
    energy = 0.5 * k * TANGENT_X0 ** 2
    for _ in range(100):
        r = sim.advance(0.01)
        s = sim.solver.state
        assert s.x - s.z >= -GAP_ROUNDING and r.impulse == 0.0
        assert (s.z, s.w) == (TANGENT_X0, 0.0)
        # the closed form, written out (1 ulp of omega_n t = 4.1e7 rad is 7e-9 rad)
        assert abs(s.x - TANGENT_X0 * math.cos(TANGENT_OMEGA * sim.t)) <= 1e-8
        assert 0.5 * (k * s.x ** 2 + m * s.v ** 2) == pytest.approx(energy, rel=1e-9)
    assert sim.impact_count == 0
    assert sim.solver.seg.search.iterations <= 2
    # at the grazes themselves (t = 2 pi j / omega_n), to the rounding of the gap
    period = 2.0 * math.pi / TANGENT_OMEGA
    graze = _tangent_ringing(u)
    for _ in range(50):
        graze.advance(period)
        assert graze.solver.state.x - graze.solver.state.z >= -GAP_ROUNDING
    assert graze.impact_count == 0


@pytest.mark.parametrize("v0", [10.0, 100.0])
def test_a_graze_deeper_than_rounding_is_still_an_impact(v0):
    """The structure released upwards at v0 from the ice's position: its envelope reaches
    (v0 / omega_n)^2 / (2 |x0|) below the ice (1.9e-13 m and 1.9e-11 m), a real impact at the
    end of the first period with closing speed v0 (energy: the structure is back at x0), to the
    speed the search's time resolution gives (curvature omega_n^2 |x0| x 8.9e-16 s)."""
    sim = _tangent_ringing(0.0, v0)
    sim.advance(1e-6)
    assert sim.impact_count == 1
    hit = sim.impacts[0]
    # x0 cos(omega t) + (v0 / omega) sin(omega t) = x0 again at omega t = 2 pi - 2 atan(...)
    back = (2.0 * math.pi - 2.0 * math.atan(v0 / TANGENT_OMEGA / abs(TANGENT_X0))) / TANGENT_OMEGA
    assert abs(hit.t - back) <= 2.0 * TIME_RESOLUTION
    resolution = TANGENT_OMEGA ** 2 * abs(TANGENT_X0) * 2.0 * TIME_RESOLUTION
    assert abs(hit.w_minus - hit.v_minus - v0) <= resolution


#: the random search's scene (tools/random_search.py --method 1 --seed 12 --scales --flows): the
#: bodies together at -0.57 m/s, omega of the bodies together 3.9e7 rad/s, a linear drag b u of
#: 5.7e6 N (flow 6478 m/s); run at 0.37 s steps with the flow reversing at every step
RINGING_IN_CONTACT = dict(
    structure_m=3537.1073490753306, structure_c=0.0, structure_k=1.0599269884926448e+19,
    structure_x0=0.0, structure_v0=-0.5706191297623756, ice_M=3619.4971632535407,
    ice_A=1.282686929497336, ice_Cd=1.0689804569440564, ice_z0=0.0,
    ice_v0=-0.5706191297623756, impact_e=0.0, drag_model=1, drag_v_lin=1.282686929497336,
    flow_u=6478.176589776202, solver_method=1)


def test_bodies_ringing_stiffly_in_contact_stick_without_work_per_period():
    """After a chatter the bodies stick ringing with 3e-13 m (their contact force between 4.2e6
    and 7.2e6 N): the search for a separation took two Taylor steps per period (1.6e-7 s), over
    10 s of CPU for the first 0.37 s step. The oscillating part of the contact force is a free
    response, so its envelope proves the force compressive for the whole phase at once. The run
    with the flow reversing every step stays sound."""
    scene = Scene(**RINGING_IN_CONTACT)
    sim = Simulator(scene)
    sim.advance(0.01)
    seg = sim.solver.seg
    assert isinstance(seg, LinearStick) and seg.search.iterations <= 2
    sim.advance(0.36)
    u = scene.flow_u
    for i in range(1, 9):
        r = sim.advance(0.37, u if i % 2 == 0 else -u)
        s = sim.solver.state
        assert all(map(math.isfinite, (r.x, r.v, r.z, r.w, r.impulse)))
        assert s.x - s.z >= -GAP_ROUNDING
        momentum = (scene.structure_m + scene.ice_M) * (abs(s.v) + abs(s.w) + u)
        assert r.impulse >= -1e-9 * momentum
    assert sim.solver.seg.search.iterations < 100


@pytest.mark.parametrize("fraction", [0.5, 0.99, 1.01, 2.0])
def test_the_sticking_clearance_agrees_with_the_written_out_contact_force(fraction):
    """The random search's sticking pair ringing about its equilibrium b u / k with an amplitude
    of ``fraction`` times the one at which its contact force lam = b (u - v) - M x'' first
    touches zero: below it the clearance proves the force compressive for ever (checked on 50
    periods of the damped closed form written out here), above it proves nothing and the
    search finds the separation where the written-out force crosses zero."""
    scene, x_eq, v0, lam, period = _ringing_pair(fraction, RINGING_IN_CONTACT)  # sigma ~ 0.06 1/s
    solver = Simulator(scene).solver
    u = scene.flow_u
    t = np.linspace(0.0, 50.0 * period, 200_001)
    values = lam(t)
    seg = LinearStick(solver, 0.0, x_eq, v0, u)
    root = seg.next_event(50.0 * period)
    if fraction < 1.0:
        assert seg.clearance(0.0) == math.inf and root is None
        assert values.min() > 0.0 and seg.search.iterations == 1
    else:
        assert seg.clearance(0.0) == 0.0
        i = int(np.argmax(values < 0.0))
        exact = brentq(lam, t[i - 1], t[i], xtol=1e-30, rtol=1e-15)
        assert abs(root - exact) <= 2.0 * TIME_RESOLUTION


#: fix 14's pair with its ice 82 mg heavier and a smaller floe (the random search's replay on
#: the code of fix 27, docs/robustness.md fix 28): after its chatter the pair rings in contact
#: 23 N beyond the drag force b u = 2.1e4 N, and the exact motion parts for 5.8e-9 s a period
#: (a gap of ~2e-19 m), re-contacting at a closing speed of rounding
STICK_PART_CYCLE = dict(
    structure_m=3537.1073490753306, structure_c=0.0, structure_k=1.0599269884926448e+19,
    structure_x0=0.0, structure_v0=-0.5706191297623756, ice_M=3537.1074305202383,
    ice_A=0.004848231011100569, ice_Cd=1.0689804569440564, ice_z0=0.0,
    ice_v0=-0.5706191297623756, fluid_rho=999.0, impact_e=0.0, drag_model=1,
    drag_v_lin=1.282686929497336, flow_u=6478.176589776202, solver_method=1)

#: events (impacts, separations, touches) a 0.37 s step of the scenes below may take; the code
#: before fix 28 took 84,000 in 20 s of CPU without ending the first step
_MAX_EVENTS_PER_STEP = 2000


def _ulps(value: float, n: int) -> float:
    for _ in range(abs(n)):
        value = math.nextafter(value, math.inf if n > 0 else 0.0)
    return value


@pytest.mark.parametrize("change", [
    {}, {"flow_u": 1}, {"flow_u": 2}, {"ice_M": -1}, {"flow_u": -1}, {"ice_M": 1}])
def test_a_stiff_pair_ringing_barely_beyond_its_drag_is_held_through_its_tension(change):
    """The stiff pair's contact force dips 23 N below zero for 2.4e-9 s a period (1.6e-7 s):
    the exact motion parts there with a gap of ~2e-19 m (GAP_ROUNDING is 1e-12 m) and
    re-contacts at a closing speed of rounding, merged; the step never ended. Such a tension is
    now held (LinearStick._tension_unresolvable): 3 s at 0.37 s steps, the flow reversing at
    every step, in bounded work, the gap never negative, every step impulse >= -1e-9 of the
    momentum scale and equal to the ice's momentum balance. The scene's one-ulp neighbours
    (flow.u one or two ulps either way, ice.M one ulp either way) alike."""
    params = dict(STICK_PART_CYCLE)
    for name, n in change.items():
        params[name] = _ulps(params[name], n)
    scene = Scene(**params)
    sim = Simulator(scene)
    solver = sim.solver
    event = solver._event
    count = [0]

    def counted(*args):
        count[0] += 1
        if count[0] > _MAX_EVENTS_PER_STEP:
            raise AssertionError(f"over {_MAX_EVENTS_PER_STEP} events in a step")
        return event(*args)

    solver._event = counted
    b, M, m = scene.drag_b, scene.ice_M, scene.structure_m
    u0 = scene.flow_u
    for i in range(9):
        h = min(0.37, 3.0 - sim.t)
        u = u0 if i % 2 == 0 else -u0
        count[0] = 0
        before = solver.state
        r = sim.advance(h, u)
        s = solver.state
        assert s.x - s.z >= 0.0
        momentum = (m + M) * (abs(s.v) + abs(s.w) + abs(u)) + scene.structure_k * abs(s.x) * h
        assert r.impulse >= -1e-9 * momentum
        # the ice's momentum balance over the step: M dw = b (u h - dz) - impulse
        balance = b * (u * h - (s.z - before.z)) - M * (s.w - before.w)
        terms = b * (abs(u) * h + abs(s.z - before.z)) + M * (abs(s.w) + abs(before.w))
        assert abs(r.impulse - balance) <= 1e-12 * terms
        assert solver.seg.search.iterations < 100
    assert sim.t == pytest.approx(3.0)


def _ringing_pair(fraction: float, fields: dict | None = None):
    """A pair ringing in contact (``fields``, STICK_PART_CYCLE by default) together at its
    equilibrium b u / k, moving at ``fraction`` times the speed at which its contact force
    first touches zero; the written-out force lam(t) and its period. lam = b u - b v - M a, with
    a = -omega2 y - 2 sigma v: its oscillating part has the amplitude
    A sqrt((M omega2)^2 + (b omega)^2) for y = A sin(omega t)."""
    scene = Scene(**(STICK_PART_CYCLE if fields is None else fields))
    b, u, M, k = scene.drag_b, scene.flow_u, scene.ice_M, scene.structure_k
    total, damping = scene.structure_m + M, scene.structure_c + b
    sigma, omega2 = damping / (2.0 * total), k / total
    wd = math.sqrt(omega2 - sigma ** 2)
    touching = b * u / math.hypot(M * omega2, b * math.sqrt(omega2))
    v0 = -fraction * touching * math.sqrt(omega2)

    def lam(t):
        decay, cos, sin = np.exp(-sigma * t), np.cos(wd * t), np.sin(wd * t)
        y = decay * v0 / wd * sin
        v = decay * (v0 * cos - sigma * v0 / wd * sin)
        return b * (u - v) - M * (-(damping * v + k * y) / total)

    return scene, b * u / k, v0, lam, 2.0 * math.pi / wd


@pytest.mark.parametrize("excess", [1e-3, 3e-2, 0.1])
def test_only_a_tension_too_slight_to_part_the_pair_resolvably_is_held(excess):
    """Fix 28's threshold on the stiff pair (b u = 2.1e4 N, omega 3.9e7 rad/s): ringing 1e-3
    beyond the amplitude at which its contact force touches zero, the force dips 21 N below
    zero for 2.3e-9 s a period (checked on 50 written-out periods): a relative speed of
    2.8e-11 m/s, far below the rounding of the speeds (6.5e-9 m/s), so the phase is proven at
    once and its step impulses stay >= -1e-12 of the momentum scale. At 3e-2 and 0.1 beyond
    (relative speeds of 4.6e-9 and 2.7e-8 m/s: the latter resolvable) the separation search
    runs: 3e-2 is held, 0.1 parts where the written-out force crosses zero."""
    scene, y_rest, v0, lam, period = _ringing_pair(1.0 + excess)
    solver = Simulator(scene).solver
    seg = LinearStick(solver, 0.0, y_rest, v0, scene.flow_u)
    t = np.linspace(0.0, 50.0 * period, 400_001)
    values = lam(t)
    assert values.min() < 0.0  # the exact force does turn tensile
    root = seg.next_event(50.0 * period)
    mu = scene.structure_m * scene.ice_M / (scene.structure_m + scene.ice_M)
    depth = -values.min()
    stretch = np.count_nonzero(values[: len(t) // 50] < 0.0) * (t[1] - t[0])
    if excess < 0.05:
        assert root is None and seg.search.iterations == 1
        assert depth * stretch / mu <= 1e-12 * scene.flow_u
        momentum = (scene.structure_m + scene.ice_M) * scene.flow_u
        for a in t[:: 4_000][:-1]:  # steps of half a period
            assert seg.impulse(a, a + 0.5 * period) >= -1e-12 * momentum
    else:
        assert seg.clearance(0.0) == 0.0
        i = int(np.argmax(values < 0.0))
        exact = brentq(lam, t[i - 1], t[i], xtol=1e-30, rtol=1e-15)
        assert abs(root - exact) <= 2.0 * TIME_RESOLUTION


def test_a_separation_opening_a_resolvable_gap_still_flies():
    """The stiff pair ringing a thousand times beyond the amplitude at which its contact force
    touches zero: its tension is not held, the bodies part and fly, and the gap opens beyond
    GAP_ROUNDING (to 2.4e-10 m)."""
    scene, y_rest, v0, lam, period = _ringing_pair(1e3)
    scene = Scene(**dict(STICK_PART_CYCLE, structure_x0=y_rest, ice_z0=y_rest,
                         structure_v0=v0, ice_v0=v0))
    sim = Simulator(scene)
    widest, flew = 0.0, False
    for _ in range(400):
        sim.advance(period / 40.0)
        s = sim.solver.state
        assert s.x - s.z >= 0.0
        widest = max(widest, s.x - s.z)
        flew = flew or not sim.solver.sticking
    assert flew and widest > GAP_ROUNDING


@pytest.mark.parametrize("excess", [1e-4, 1e-3])
def test_a_tension_within_speed_rounding_that_opens_a_resolvable_gap_still_parts(excess):
    """A slow pair (omega 1 rad/s) under a faint drag (b u = 0.064 N) ringing 1e-4 and 1e-3
    beyond the energy radius at which its contact force touches zero: the tension gives a
    relative speed within the rounding of the speeds (1e-10 and 3.3e-9 m/s, below
    6.5e-9 m/s), but over its stretch (0.03 and 0.09 s) it opens a gap beyond GAP_ROUNDING
    (1.6e-12 and 1.6e-10 m), so it is not held: the bodies part where the force crosses zero
    and fly for about twice the tensile stretch."""
    params = dict(STICK_PART_CYCLE, structure_k=7074.0, ice_A=1.45e-8)
    scene = Scene(**params)
    solver = Simulator(scene).solver
    b, u, k = scene.drag_b, scene.flow_u, scene.structure_k
    rest = b * u / k
    seg = LinearStick(solver, 0.0, rest, -1.0, u)
    _, _, q, rate, _ = seg._force(0.0)
    v0 = -(1.0 + excess) * seg._push / seg.osc.amplitude_bound(q, rate)  # q is linear in v0
    seg = LinearStick(solver, 0.0, rest, v0, u)
    assert seg.clearance(0.0) == 0.0
    period = 2.0 * math.pi / seg.osc.omega
    root = seg.next_event(period)
    assert root is not None and seg.force(root) <= 1e-12 * seg._push
    sim = Simulator(Scene(**dict(params, structure_x0=rest, ice_z0=rest, structure_v0=v0,
                                 ice_v0=v0)))
    sim.advance(root * (1.0 - 1e-9))
    stretch = 2.0 * math.sqrt(2.0 * excess) / seg.osc.omega  # the tension's duration, ~
    widest, flying = 0.0, 0
    for _ in range(400):
        sim.advance(stretch / 100.0)
        s = sim.solver.state
        assert s.x - s.z >= 0.0
        widest = max(widest, s.x - s.z)
        flying += not sim.solver.sticking
    assert widest > GAP_ROUNDING and 150 <= flying <= 250


# --- the root search at scales whose squares underflow ------------------------------------------

@pytest.mark.parametrize("speed", [2.5818798841184776e-288, 2.5818798841184776e-8])
def test_a_sticking_separation_at_scales_whose_squares_underflow_is_found(speed):
    """The random search's pair together at x = 0 moving at 2.6e-288 m/s, no drag, no flow: they
    ring together, x = (v0 / W) sin(W t) with W^2 = k / (m + M), and the contact force
    M k x / (m + M) turns tensile at t = pi / W, where the bodies part. The bounds on the force's
    derivatives (sums of squares of 1e-284) underflowed to 0, which told the search the force
    was linear, and then its Taylor stretch (a discriminant underflowing) spanned 1e14 s: the
    bodies stayed stuck through the tensile half-period (impulses of -0.1 of the momentum). The
    separation is now found at pi / W at any scale."""
    scene = Scene(structure_m=0.005189569780122153, structure_c=0.0,
                  structure_k=108.73418605233162, structure_x0=0.0, structure_v0=speed,
                  ice_M=0.005189569780122153, ice_A=1.0, ice_Cd=0.0, ice_z0=0.0, ice_v0=speed,
                  impact_e=0.0, drag_model=1, flow_u=0.0, solver_method=1)
    sim = Simulator(scene)
    for _ in range(5):
        r = sim.advance(0.01, 0.0)
        assert r.impulse >= 0.0 and r.gap >= 0.0
    apart = math.pi / math.sqrt(scene.structure_k / (scene.structure_m + scene.ice_M))
    assert not sim.sticking and isinstance(sim.solver.seg, Flight)
    assert abs(sim.solver.seg.t0 - apart) <= 1e-12


def test_a_pair_1e_240_m_from_equilibrium_parts_after_a_quarter_period():
    """The random search's stiff pair (W = sqrt(k / (m + M)) = 6.5e6 rad/s) resting together
    4.7e-240 m from the spring's rest point under a linear drag and a flow of +-2.2e-308 m/s:
    the contact force M k x / (m + M) (drag terms of relative size 1e-3 over the 2.4e-7 s)
    turns tensile at a quarter period, pi / (2 W). Its probes underflowed as above and the
    bodies stayed stuck with tensile impulses of -3.3e-230 N.s per 0.1 ms step."""
    scene = Scene(structure_m=245311.84342942314, structure_c=0.0,
                  structure_k=1.1008881654443012e+19, structure_x0=4.663560638713423e-240,
                  structure_v0=0.0, ice_M=12576.335271001795, ice_A=35.963144812094825,
                  ice_Cd=1.5558576617826123, ice_z0=4.663560638713423e-240, ice_v0=0.0,
                  impact_e=0.0, drag_model=1, drag_v_lin=0.2423178017375031,
                  flow_u=-2.2250738585072014e-308, solver_method=1)
    sim = Simulator(scene)
    u = scene.flow_u
    quarter = 0.5 * math.pi / math.sqrt(scene.structure_k / (scene.structure_m + scene.ice_M))
    for i in range(50):
        r = sim.advance(1e-4, u if i % 2 == 0 else -u)
        assert r.impulse >= 0.0 and r.gap >= 0.0
        assert math.isfinite(r.x) and math.isfinite(r.z)
        if i == 0:  # the flight that follows starts at the separation
            assert isinstance(sim.solver.seg, Flight)
            assert abs(sim.solver.seg.t0 - quarter) <= 1e-6 * quarter
    assert sim.impact_count == 0 and not sim.sticking


@pytest.mark.parametrize("exponent", [-1000, -960, 900])
def test_the_root_search_does_not_depend_on_the_scale_of_its_signal(exponent):
    """f = s cos t (|f''|, |f'''| <= s), first root pi / 2: the same root, to the bit, for s = 1
    and for scales whose squares underflow (2^-960, 2^-1000, subnormal) or overflow (2^900); and
    the amplitude bound of a free response at such scales is the scaled one."""
    def root_for(s):
        def probe(t):
            return s * math.cos(t), -s * math.sin(t), -s * math.cos(t), s, s
        search = RootSearch(0.0, TIME_RESOLUTION)
        return search.next_root_before(10.0, probe, lambda t: s * math.cos(t),
                                       lambda t: (s * math.cos(t), -s * math.sin(t)))
    scale = math.ldexp(1.0, exponent)
    assert root_for(scale) == root_for(1.0)
    assert abs(root_for(1.0) - 0.5 * math.pi) <= 1e-15 + 2e-15 * 0.5 * math.pi  # its tolerance
    osc = Oscillator(2.0, 0.0, 8.0)  # omega_n = 2
    if exponent > -1000:  # (a subnormal scale keeps fewer bits)
        assert osc.amplitude_bound(3.0 * scale, 8.0 * scale) == pytest.approx(5.0 * scale,
                                                                               rel=1e-15)


#: random-search scenes at the ends of double precision where nothing can happen (the ice out of
#: reach or at rest, no drag or no flow): (scene, communication step, flow of steps 0-3 in turn)
FROZEN_EXTREMES = {
    # the ice 0.067 m beyond the reach of a stiff structure, crawling at 1e-308 m/s: the
    # clearance (margin / speed) was 6e306 s, and the gap was evaluated at omega_n t = inf
    # (ValueError from math.cos); the search's k was 3.77e11 N/m, now above method 1's sticking
    # rate rule (TAYLOR_RATE_MAX) with quadratic drag: 3.0e10 keeps the scene within it, the
    # structure's reach and the ice's crawl as they were
    "ice crawling at 1e-308 m/s": (dict(
        structure_m=0.00043926462461252146, structure_c=0.0, structure_k=3.0e10,
        structure_x0=-0.41809125917960344, structure_v0=1.1125369292536007e-308,
        ice_M=3.306966185946854, ice_A=0.004425684103770009, ice_Cd=1e-15,
        ice_z0=-0.48545371398205006, ice_v0=1.1125369292536007e-308,
        impact_e=0.21608311446586376, drag_model=2, drag_v_lin=0.0016833848398599407,
        flow_u=0.0), 1e-4, (0.0,) * 4),
    # a structure ringing with 2e-196 m, the ice 0.022 m away: d2^2 and jerk * df both
    # underflow in the root search (a division by their sum, 0)
    "structure ringing with 2e-196 m": (dict(
        structure_m=5.047249916897516e-05, structure_c=0.0, structure_k=117694843.24735996,
        structure_x0=0.0, structure_v0=-3.042972614185134e-190, ice_M=5.047249916897518e-05,
        ice_A=0.004359259021143864, ice_Cd=0.0, ice_z0=-0.02210596527455649, ice_v0=0.0,
        impact_e=1.0, drag_model=1, drag_v_lin=0.0037798570126214757, flow_u=0.0), 0.37,
        (0.1, 0.1, 0.1, -0.1)),
    # the ice 2.2e-309 m (subnormal) upstream of a structure at rest: a probe of subnormal size
    # (its scale 2^1073 overflows; at most 2^1000 is used)
    "gap of 2.2e-309 m": (dict(
        structure_m=1.0, structure_c=197.9384957220146, structure_k=9794.9120221735,
        structure_x0=0.0, structure_v0=0.0, ice_M=1.0, ice_A=1.0, ice_Cd=0.0,
        ice_z0=-2.225073858507203e-309, ice_v0=0.0, impact_e=1.0, drag_model=2,
        drag_v_lin=1.1650348848649137, flow_u=0.0), 1e-3, (0.1,) * 4),
}


@pytest.mark.parametrize("name", list(FROZEN_EXTREMES))
def test_scenes_at_the_ends_of_double_precision_run_soundly(name):
    kw, h, flows = FROZEN_EXTREMES[name]
    scene = Scene(**kw, solver_method=1)
    sim = Simulator(scene)
    # the structure's envelope: |x| <= sqrt(x0^2 + (v0 / omega_n)^2) (its energy), the ice still
    lowest = -math.hypot(scene.structure_x0, scene.structure_v0 / scene.omega_n) - scene.ice_z0
    for i in range(8):
        r = sim.advance(h, flows[i % 4])
        values = (r.x, r.v, r.z, r.w, r.gap, r.impulse)
        assert all(map(math.isfinite, values)) and r.impulse == 0.0
        assert r.gap >= lowest - GAP_ROUNDING  # out of reach
    assert sim.impact_count == 0


# --- method 3: stiffness, found by tools/random_search.py --method 3 --scales --flows ----------

def _search_case(scene: dict, h: float, flow: str, signs: list[bool]) -> dict:
    """A case as the random search prints it on its REPLAY line (defaults for the other
    fields), for random_search.replay."""
    return {"scene": {**Scene().__dict__, **scene}, "h": h, "flow": flow, "signs": signs,
            "time_limit": 10.0}


#: A critically damped structure (omega_n 3.96e3 rad/s, c / m = 7.9e3 1/s) come to rest after
#: an impact, its states 1e-24 m and below, the ice at rest at its equilibrium; no drag.
AT_REST_BELOW_TOLERANCE = dict(
    structure_m=0.004822483396403491, structure_c=38.23747872592765,
    structure_k=75796.2578163658, structure_x0=0.0, structure_v0=2.2250738585072014e-308,
    ice_M=0.004822483396403491, ice_A=0.10000230261160267, ice_Cd=0.0, ice_z0=0.0,
    ice_v0=-8.232872664026076e-167, impact_e=1.0, drag_model=1, drag_v_lin=1.000000000007083,
    flow_u=0.0, solver_method=3)


def test_method_3_at_rest_below_its_tolerance_does_not_ring_through_the_ice():
    """With states far below the absolute tolerance the error control let DOP853's steps grow
    to 1e-2 s, 80 times c / m past its stability bound: the unstable steps' dense output rang
    the structure 2.5e-10 m past the ice (25 times the tolerance). Steps are now bounded by
    STABLE_STEP / rate. Independent check: the exact method's positions, within 10 atol."""
    from iceimpact.solvers.ode import STABLE_STEP

    ode = Simulator(Scene(**AT_REST_BELOW_TOLERANCE))
    exact = Simulator(Scene(**{**AT_REST_BELOW_TOLERANCE, "solver_method": 1}))
    tolerance = 10 * ode.solver.atol  # 1e-10 m
    for _ in range(1000):
        ode.advance(1e-3, 0.1)
        exact.advance(1e-3, 0.1)
        s = ode.solver.state
        assert s.x - s.z >= -tolerance
        assert abs(s.x - exact.solver.state.x) <= tolerance
    rate = 38.23747872592765 / 0.004822483396403491  # c / m
    assert ode.solver._max_step(ode.solver.y_now) == pytest.approx(STABLE_STEP["DOP853"] / rate)


@pytest.mark.parametrize("case", [
    # a damped structure and a floe resting on it at 5.7e-279 m/s, no flow (quadratic drag):
    # contact impulses of -2.5e-282 N.s, 1e-4 of the momentum scale, from unstable steps
    _search_case(dict(structure_m=4.397240511281057, structure_c=417.67189687553866,
                      structure_k=9918.141445303148, structure_x0=0.0,
                      structure_v0=5.674991271961134e-279, ice_M=4.397240511281057,
                      ice_A=1.0, ice_Cd=1.0, ice_z0=0.0, ice_v0=5.674991271961134e-279,
                      impact_e=1.0, drag_model=2, drag_v_lin=0.0034023056836142845,
                      flow_u=0.0, solver_method=3), 1e-3, "zero", [True]),
    # a 33 mg floe on a 33 mg structure (omega_n 0.03 rad/s), linear drag b/M = 6.4e4 1/s,
    # flow signs at random: over 10 s of CPU for 0.44 s (5 s chunks ahead of 10 ms steps),
    # then a tensile impulse of -5.9e-20 N.s (5.5e-5 of the momentum scale)
    _search_case(dict(structure_m=3.300050358924868e-05, structure_c=9.670628403318691e-07,
                      structure_k=3.242253559770527e-08, structure_x0=1.401298464324817e-45,
                      structure_v0=0.0, ice_M=3.300050358924875e-05,
                      ice_A=0.2803355045709724, ice_Cd=1.5, ice_z0=1.401298464324817e-45,
                      ice_v0=1.401298464324817e-45, impact_e=1.0, drag_model=1,
                      drag_v_lin=0.010049579393317814, flow_u=8.9e-16, solver_method=3),
                 0.01, "random signs", [True, False, False, True, True, True, False, True,
                                        True, False, True, False, False, False, True, False]),
    # a critically damped structure (omega_n 1e4 rad/s) leaving the ice at rest, no flow: with
    # stable steps its decay is followed to underflow, positions 0 and speeds 1e-319 m/s, and
    # every step met a gap of exactly 0 as an event (over 10 s of CPU in the first 0.37 s step)
    _search_case(dict(structure_m=100.0023026116027, structure_c=2000046.0522320517,
                      structure_k=10000230261.160248, structure_x0=0.0,
                      structure_v0=0.990468330088397, ice_M=100.0023026116027,
                      ice_A=0.049139914759806544, ice_Cd=7.439588730544905e-235, ice_z0=0.0,
                      ice_v0=0.0, impact_e=0.0, drag_model=1, drag_v_lin=1.0,
                      flow_u=4509.90874376061, solver_method=3), 0.37, "zero", [True, False]),
    # the bodies at zero gap, the ice parting at 6.9e-213 m/s (2e-200 of the velocities'
    # tolerance) while the drag presses it back: method 3 takes the parting for integration
    # noise and sticks them with a plastic entry, -6.8e-213 N.s; the search flagged the step's
    # -1.7e-215 N.s against a momentum scale of 2e-212 until its impulse check took method 3's
    # absolute tolerance, mu PARTING_NOISE atol (1e-10 N.s), as its gap check does
    _search_case(dict(structure_m=1.0, structure_c=0.0, structure_k=4.718601971181243,
                      structure_x0=-2.2250738585e-313, structure_v0=-2.1061441388102723e-255,
                      ice_M=126.90283035995253, ice_A=3.781832400600783,
                      ice_Cd=0.654572658341806, ice_z0=-2.2250738585e-313,
                      ice_v0=-6.880602889092191e-213, impact_e=0.0, drag_model=1,
                      drag_v_lin=9.53930163557974, flow_u=0.0, solver_method=3),
                 10.0, "zero", [True]),
], ids=["at-rest-u0-quadratic", "light-floe-random-signs", "decay-to-underflow",
        "parting-below-tolerance"])
def test_method_3_search_cases_run_soundly(case):
    """Replayed exactly as the random search ran them (its checks are the independent ones:
    finite, gap >= -10 atol, impulse >= -1e-5 of the momentum scale, no energy created at
    u = 0) within its 10 s CPU limit."""
    from random_search import replay

    outcome = replay(case)
    assert outcome.fault is None and not outcome.refused
    assert outcome.t == pytest.approx(1.0 if case["h"] >= 1e-3 else 0.05)


def test_method_3_a_stiff_drag_on_a_slow_structure_does_not_integrate_far_ahead():
    """A 4 g floe stuck on a slow structure (period 4600 s) under a linear drag of b/M =
    1.4e5 1/s: every solve_ivp call spanned a 5 s chunk ahead of 10 ms steps, over 10 s of CPU
    for two steps. Chunks are now at most CHUNK_RATE / rate = 0.016 s: the integration stays
    within one chunk of the time asked, and its work within ~5 evaluations per step of
    STABLE_STEP / rate (the bound) over the time integrated."""
    from iceimpact.limits import integrated_rate
    from iceimpact.solvers.ode import CHUNK_RATE, STABLE_STEP

    scene = Scene(structure_m=0.00031837387396693875, structure_c=8.662664593413903e-07,
                  structure_k=5.892581332362994e-10, structure_x0=0.0, ice_M=0.003911992529513781,
                  ice_A=1.0, ice_Cd=1.0894605948212017, ice_z0=0.0, ice_v0=0.0, impact_e=1.0,
                  drag_model=1, drag_v_lin=1.0000097396015444, flow_u=0.1, solver_method=3)
    rate = integrated_rate(scene, 0.1)
    assert rate == pytest.approx(scene.drag_b / scene.ice_M)  # 1.39e5 1/s
    sim = Simulator(scene)
    for _ in range(5):
        r = sim.advance(0.01)
        assert r.gap >= 0.0 and r.impulse >= 0.0
    assert sim.solver.chunk_hi - sim.t <= CHUNK_RATE / rate
    steps = sim.solver.chunk_hi / (STABLE_STEP["DOP853"] / rate)
    assert sim.solver.nfev <= 20 * steps  # DOP853: 12 stages + 3 for its dense output


def test_method_3_explicit_integrators_have_a_rate_limit_from_their_cost():
    """RK45 and DOP853 cost ~3e-5 s of CPU x rate per simulated second near their stability
    bound: the rate rules of method 3 refuse above ODE_EXPLICIT_RATE_MAX = 3e5 1/s (10 s per
    simulated second), naming the combination, its value, the limit and the integrator, and
    pointing at LSODA, which keeps DRAG_RATE_MAX; method 1 keeps DRAG_RATE_MAX too."""
    from iceimpact.limits import ODE_EXPLICIT_RATE_MAX

    assert ODE_EXPLICIT_RATE_MAX == 3e5 and DRAG_RATE_MAX == 1e6
    light = dict(ice_M=1e-3, ice_A=1.0, ice_Cd=1.0, drag_model=1, solver_method=3)
    for ode_method, name in [(1, "RK45"), (2, "DOP853")]:
        with pytest.raises(ParameterError) as err:
            Scene(**light, drag_v_lin=1.0, solver_ode_method=ode_method)  # b/M = 5e5 1/s
        message = str(err.value)
        assert message.startswith("B * drag.v_lin / ice.M = 499500.0 is not allowed: <= 300000")
        assert f"solver.ode_method = {ode_method} ({name})" in message
        assert "solver.ode_method = 3 (LSODA" in message and "1e+06 1/s" in message
        with pytest.raises(ParameterError, match=r"structure.c / structure.m = 400000.0 .*"
                                                 r"<= 300000 1/s"):
            Scene(structure_c=4e5 * 1600.0, solver_method=3, solver_ode_method=ode_method)
        Scene(structure_c=2.9e5 * 1600.0, solver_method=3, solver_ode_method=ode_method)
    for ode_method in (3, 4):
        Scene(**light, drag_v_lin=1.0, solver_ode_method=ode_method)
    # mid-run, a flow whose quadratic drag rate exceeds the explicit limit is refused
    sim = Simulator(Scene(drag_model=2, solver_method=3))
    sim.advance(1e-3)
    u_max = ODE_EXPLICIT_RATE_MAX * 1600.0 / (2.0 * 499.5)
    with pytest.raises(ParameterError, match=r"flow.u = .* is not allowed: \|flow.u\| <= 4.8e"):
        sim.advance(1e-3, 1.01 * u_max)
    sim.advance(1e-3, 0.99 * u_max)


@pytest.mark.parametrize("kind", ["over-damped flight", "over-damped stuck", "linear drag"])
def test_method_3_work_per_simulated_second_is_proportional_to_the_rate(kind):
    """Just inside the explicit limit (0.99 x 3e5 1/s), the flow reversed at every 1 ms step:
    the work over the time integrated is proportional to the rate, 7 to 9 evaluations x rate
    per simulated second (DOP853: 15 per step of at most STABLE_STEP / rate, with rejected
    steps and restarts), the cost the limit was derived from; independent of CPU speed."""
    from iceimpact.limits import ODE_EXPLICIT_RATE_MAX

    rate = 0.99 * ODE_EXPLICIT_RATE_MAX
    if kind == "over-damped flight":
        scene = Scene(structure_m=1.0, structure_k=1e8, structure_c=rate, structure_x0=0.01,
                      ice_M=1e-3, ice_Cd=0.0, ice_z0=-1.0, solver_method=3)
    elif kind == "over-damped stuck":
        scene = Scene(structure_m=1.0, structure_k=1e8, structure_c=rate, structure_x0=0.0,
                      structure_v0=0.0, ice_M=1e-3, ice_z0=0.0, ice_v0=0.0, solver_method=3)
    else:
        scene = Scene(ice_M=1e-3, ice_A=1.0, ice_Cd=1.0, drag_model=1,
                      drag_v_lin=rate * 1e-3 / 499.5, solver_method=3)
    sim = Simulator(scene)
    for i in range(20):
        r = sim.advance(1e-3, 0.1 if i % 2 == 0 else -0.1)
        assert r.gap >= 0.0 and r.impulse >= 0.0 and math.isfinite(r.x)
    assert sim.solver.nfev <= 12.0 * rate * sim.solver.chunk_hi


#: The random search's slow method-3 scene (seed 46): a 0.34 mg floe on a 1.8 g structure
#: (omega_n 0.16 rad/s, chatter time 0.39 s), linear drag b / M = 2.9e5 1/s (just inside the
#: explicit limit), e = 0.7, 1 ms steps with the flow reversed one step in four.
LIGHT_FLOE_NEAR_THE_RATE_LIMIT = _search_case(
    dict(structure_m=0.0018329234721427574, structure_c=0.0005841447487010957,
         structure_k=4.654109849934993e-05, structure_x0=4.177705884955332e-267,
         structure_v0=1e-16, ice_M=3.3519054173469566e-07, ice_A=0.19282973629443662,
         ice_Cd=0.5503080240880754, ice_z0=4.177705884955332e-267,
         ice_v0=-0.00013118567765448426, impact_e=0.7045244644744516, drag_model=1,
         drag_v_lin=0.0018488068422214442, flow_u=0.0, solver_method=3),
    1e-3, "reversed 1 in 4", [False, True, False, False, True, True, False])


def test_method_3_sticking_steps_are_bounded_by_the_rate_of_the_bodies_together():
    """Stuck, the bodies integrate (m + M) x'' + (c + b) x' + k x = b u: their rate is
    (c + b) / (m + M), 53 1/s for the light floe, not the floe's own b / M = 2.9e5 1/s in
    flight, which bounded the sticking steps to 1.7e-5 s (6,094 evaluations for its first
    3 ms, stuck from 9e-9 s). The rate of the bodies together is a mediant of the flight's:
    never above the larger of (c + b_s) / (m + m_a) and b / M (or 2 B speed / M)."""
    from iceimpact.limits import integrated_rate
    from iceimpact.solvers.contact_rules import Phase
    from iceimpact.solvers.ode import STABLE_STEP

    scene = Scene(**LIGHT_FLOE_NEAR_THE_RATE_LIMIT["scene"])
    sim = Simulator(scene)
    for _ in range(3):
        r = sim.advance(1e-3, 0.1)
        assert r.gap >= 0.0 and r.impulse >= 0.0
    assert sim.solver.phase is Phase.STICK
    assert sim.solver.nfev < 500
    together = (scene.structure_c + scene.drag_b) / (scene.structure_m + scene.ice_M)
    assert sim.solver._max_step(sim.solver.y_now) == pytest.approx(STABLE_STEP["DOP853"]
                                                                  / together)
    assert integrated_rate(scene, 0.1, together=True) == pytest.approx(together, rel=1e-15)
    for fields in [dict(), dict(drag_model=2, ice_A=2.0), dict(ice_M=6400.0, flow_u=2.0),
                   dict(structure_c=3000.0), dict(structure_Cd=1.0, structure_A=1.0),
                   dict(structure_Cd=1.0, structure_A=1.0, drag_model=2),
                   LIGHT_FLOE_NEAR_THE_RATE_LIMIT["scene"]]:
        sc = Scene(**{**fields, "solver_method": 3})
        quadratic = sc.drag_model == 2
        speed = 0.7
        structure = (sc.structure_c + (2.0 * sc.structure_drag_B * speed if quadratic
                                       else sc.structure_drag_b)) / sc.structure_mass
        ice = 2.0 * sc.drag_B * speed / sc.ice_M if quadratic else sc.drag_b / sc.ice_M
        assert integrated_rate(sc, 0.1, speed, together=True) <= max(structure, ice)


def test_method_3_light_floe_near_the_rate_limit_costs_the_rate_rules_work():
    """The search's slow scene ran at ~70 s of CPU per simulated second: each chatter-closed
    impact (every 4 ms) counted as a degenerate contact, so that from the ninth on the bodies
    were held for 2^n ns, doubling up to the chatter time, 0.39 s; each hold was integrated
    whole in one call at the flight's step bound (345,842 evaluations for 0.39 s) and thrown
    away at the flow change 1 ms later: 1.3e6 evaluations in the first 0.083 s, 91 % of them in
    holds. A hold is now integrated in the segment's spans (never more than a chunk ahead) and
    sticking steps are bounded by the bodies' own rate: the work stays within 4 evaluations x
    b / M per simulated second, checked at every step (DOP853: 15 per step of at most
    STABLE_STEP / rate = 1 / (5 rate) s, so 3 rate, plus the restarts at flow changes and
    impacts); independent of CPU speed."""
    from iceimpact.limits import integrated_rate
    from random_search import flow_at

    case = LIGHT_FLOE_NEAR_THE_RATE_LIMIT
    scene = Scene(**case["scene"])
    rate = integrated_rate(scene, 0.1)
    assert rate == pytest.approx(scene.drag_b / scene.ice_M)  # 2.9e5 1/s
    sim = Simulator(scene)
    for i in range(150):
        r = sim.advance(1e-3, flow_at(case["flow"], i, 0.1, case["signs"]))
        assert r.gap >= -10.0 * sim.solver.atol and math.isfinite(r.impulse)
        assert sim.solver.chunk_hi - sim.t <= sim.solver.chunk
        assert sim.solver.nfev <= 4.0 * rate * sim.t + 2000
    assert sim.impact_count >= 30
    # (its holds, each chatter-closed impact counted as a degenerate contact, are gone with fix
    # 32: a hold integrated in spans is pinned by the next test)


def test_method_3_a_forced_hold_is_integrated_in_the_segments_spans():
    """A forced hold (bodies together, separation not looked for until its end: a degenerate
    contact, or events repeating at one instant) of the chatter time, 0.39 s for this slow
    structure, was integrated whole in one call at the step bound of fix 30's light floe
    (345,842 evaluations) and thrown away at the next flow change. It is now integrated in the
    segment's spans, never more than a chunk ahead of the time asked, and its end is still where
    the contact logic decides again."""
    from iceimpact.solvers.contact_rules import Phase

    case = LIGHT_FLOE_NEAR_THE_RATE_LIMIT
    scene = Scene(**dict(case["scene"], structure_x0=0.0, ice_z0=0.0, structure_v0=0.0,
                         ice_v0=0.0))
    sim = Simulator(scene)
    solver = sim.solver
    sim.advance(1e-3, 0.1)
    hold = solver.rules.chatter_time
    assert hold == pytest.approx(0.39, rel=0.02)
    x, v = solver.state.x, solver.state.v
    solver._segment(Phase.STICK, sim.t, [x, v, 0.0], hold=hold)
    start, nfev0 = sim.t, solver.nfev
    for _ in range(20):
        sim.advance(1e-3, 0.1)
        assert solver.chunk_hi - sim.t <= solver.chunk
        assert solver.hold_until == pytest.approx(start + hold)
    assert solver.nfev - nfev0 < 20000  # the hold whole: ~3.5e5


def test_method_3_radau_has_limits_from_its_steps_per_period_and_tolerance():
    """Radau's error estimate is of order 3: its steps per period of the structure and per
    relaxation after a flow change grow as rtol^(-1/4), whatever the rate (~350 per period and
    150-300 per flow change at rtol 1e-8; a structure ringing at 1e4 rad/s cost 82-84 s of CPU
    per simulated second). With solver.ode_method = 4 omega_n is held to 1e3 rad/s at rtol 1e-8,
    scaled as rtol^(1/4) up to OMEGA_MAX_ODE, and solver.rtol to >= 1e-10; the messages name
    the variable, its value and the range. LSODA keeps OMEGA_MAX_ODE and every rtol."""
    from iceimpact.limits import RADAU_OMEGA_MAX, RADAU_RTOL_MIN, omega_limit

    assert (RADAU_OMEGA_MAX, RADAU_RTOL_MIN) == (1e3, 1e-10)
    ringing = dict(structure_m=1.0, structure_k=1e8, structure_c=200.0, structure_x0=0.01,
                   ice_M=1e-3, ice_Cd=0.0, ice_z0=-1.0, solver_method=3)   # omega_n = 1e4
    with pytest.raises(ParameterError) as err:
        Scene(**ringing, solver_ode_method=4)
    assert str(err.value).startswith(
        "sqrt(structure.k / structure.m) = 10000.0 is not allowed: omega_n <= 1e+03 rad/s with "
        "solver.method = 3 and solver.ode_method = 4 (Radau)")
    with pytest.raises(ParameterError, match=r"omega_n <= 3.16e\+03 rad/s .*solver.rtol = 1e-06"):
        Scene(**ringing, solver_ode_method=4, solver_rtol=1e-6)
    assert Scene(**ringing, solver_ode_method=4, solver_rtol=1e-4).omega_n == 1e4
    assert omega_limit(Scene(solver_method=3, solver_ode_method=4, solver_rtol=1e-10)) == \
        pytest.approx(1e3 * 1e-2 ** 0.25)
    Scene(**{**ringing, "structure_k": 0.99e6}, solver_ode_method=4)
    with pytest.raises(ParameterError, match=r"^solver.rtol = 1e-11 is not allowed: >= 1e-10 "
                                             r"with solver.method = 3 and solver.ode_method = "
                                             r"4 \(Radau\)"):
        Scene(solver_method=3, solver_ode_method=4, solver_rtol=1e-11)
    Scene(solver_method=3, solver_ode_method=4, solver_rtol=1e-10)
    Scene(**ringing, solver_ode_method=3, solver_rtol=1e-13)  # LSODA


@pytest.mark.parametrize("kind, rate", [("linear drag", 1e3), ("linear drag", 9.9e5),
                                        ("quadratic drag", 1e3), ("quadratic drag", 9.9e5),
                                        ("ringing", 0.99e3)])
def test_method_3_radau_work_is_set_by_its_tolerance_not_the_rate(kind, rate):
    """Radau at rtol 1e-8, the flow reversed at every 1 ms step: each step costs at most ~300
    Radau steps (~7.5 evaluations each, 2200 measured at 9.9e5 1/s) whatever the drag rate
    from 1e3 to 1e6 1/s; a structure ringing at the omega_n limit, ~350 steps (~2500
    evaluations) per period. The law the Radau rules are derived from, independent of CPU
    speed (benchmarks/implicit_cost.py)."""
    from ode_rate_cost import scene as stiff_scene

    if kind == "ringing":  # omega_n = rate, zeta = 0.01, the ice out of reach
        scene = Scene(structure_m=1.0, structure_k=rate ** 2, structure_c=0.02 * rate,
                      structure_x0=0.01, ice_M=1e-3, ice_Cd=0.0, ice_z0=-1.0, solver_method=3,
                      solver_ode_method=4)
    else:
        scene = stiff_scene(kind, rate, 4)
    sim = Simulator(scene)
    steps = 10
    for i in range(steps):
        r = sim.advance(1e-3, scene.flow_u if i % 2 == 0 else -scene.flow_u)
        assert r.gap >= 0.0 and r.impulse >= 0.0 and math.isfinite(r.x)
    if kind == "ringing":
        periods = sim.solver.chunk_hi * rate / (2.0 * math.pi)
        assert sim.solver.nfev <= 3000 * periods
    else:
        assert sim.solver.nfev <= 3000 * steps


def test_method_3_implicit_integrators_get_the_exact_jacobian():
    """LSODA and Radau are given d(rhs)/dy from the same drag laws (force_rate) instead of
    estimating it by finite differences: it matches central differences of each right-hand
    side (flight, flight with the Morison drag on the structure, sticking, sticking with it)."""
    from iceimpact.solvers.contact_rules import Phase
    from iceimpact.solvers.ode import OdeSolver

    def numeric(fun, y):
        y = np.asarray(y, dtype=float)
        cols = []
        for j in range(y.size):
            h = 1e-6 * max(1.0, abs(y[j]))
            dy = np.zeros_like(y)
            dy[j] = h
            cols.append((np.asarray(fun(0.0, y + dy)) - np.asarray(fun(0.0, y - dy))) / (2 * h))
        return np.array(cols).T

    morison = dict(structure_Cd=1.0, structure_A=2.0, structure_V=1.0, structure_Ca=1.0)
    for drag_model in (1, 2):
        for extra in ({}, morison):
            scene = Scene(drag_model=drag_model, flow_u=0.3, solver_method=3,
                          solver_ode_method=4, impact_e=0.0, **extra)
            solver = OdeSolver(scene)
            assert (solver.structure_drag is not None) == bool(extra)
            for phase, y in ((Phase.FLIGHT, [0.01, -0.2, -0.05, 0.7]),
                             (Phase.STICK, [0.01, -0.2, 0.0])):
                solver._equations(phase, 0.0)
                exact = np.array(solver.rhs.jacobian(0.0, y))
                assert exact.shape == (len(y), len(y))
                assert np.allclose(exact, numeric(solver.rhs, y), rtol=1e-7, atol=1e-9), \
                    (drag_model, extra, phase)


def test_a_light_pair_sticking_far_from_its_equilibrium_parts_nothing_in_bounded_time():
    """Method 1, linear drag: a light pair (m = 2.2e-6 kg, M = 1.1e-7 kg, k = 5.2e-9 N/m) under
    b = 4e5 kg/s sticks towards an equilibrium b u / k = 7.7e12 m away, where a position's ulp
    is 1e-3 m. The contact force (k x, 5e-13 N at 0.1 mm) was evaluated as b (u - v) - M a,
    terms of b u = 4e4 N, below its own rounding: the separation search took over 60 s of
    CPU for the first 1 ms. Positions, force and impulse now come from increments from the
    anchor: each step's impulse equals the structure's momentum balance m dv + k x dt (c = 0),
    and the pair drifts with the flow."""
    import signal

    def _out_of_time(signum, frame):
        raise TimeoutError("the sticking phase took over 5 s of CPU")

    m, k, u, h = 2.2e-6, 5.2e-9, 0.1, 1e-3
    sim = Simulator(Scene(structure_m=m, structure_c=0.0, structure_k=k, structure_x0=0.0,
                          structure_v0=u, ice_M=1.1e-7, ice_A=4004.0, ice_Cd=2.0, ice_z0=0.0,
                          ice_v0=u, impact_e=0.0, drag_model=1, flow_u=u, solver_method=1))
    assert sim.scene.drag_b == pytest.approx(4e5, rel=1e-5)
    previous = signal.signal(signal.SIGPROF, _out_of_time)
    signal.setitimer(signal.ITIMER_PROF, 5.0)
    try:
        v_before, x_before = u, 0.0
        for i in range(20):
            r = sim.advance(h)
            assert r.sticking and r.impulse >= 0.0
            balance = m * (r.v - v_before) + k * 0.5 * (r.x + x_before) * h
            assert r.impulse == pytest.approx(balance, rel=1e-6, abs=1e-24)
            assert r.x == pytest.approx(u * (i + 1) * h, rel=1e-9)
            v_before, x_before = r.v, r.x
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0.0)
        signal.signal(signal.SIGPROF, previous)


def test_sticking_far_from_its_equilibrium_keeps_its_positions_exact():
    """Method 1, linear drag, the scene above (equilibrium b u / k = 6.9e7 m): positions
    written as offset + y carried the offset's rounding, 2.3e-8 m off the exact motion over
    0.2 s; as increments from the anchor they match the closed form evaluated in 50-digit
    decimal arithmetic (the over-damped motion on its two exponents) to 1e-16 m."""
    from decimal import Decimal, localcontext

    m, k, u = 1.0, 1.1779e-4, 0.1
    scene = Scene(structure_m=m, structure_c=0.0, structure_k=k, structure_x0=0.0,
                  structure_v0=0.0, ice_M=393.5, ice_A=812.19, ice_Cd=2.0, ice_z0=0.0,
                  ice_v0=0.0, impact_e=0.0, drag_model=1, flow_u=u, solver_method=1)
    sim = Simulator(scene)
    with localcontext() as ctx:
        ctx.prec = 50
        mass, damping, stiff = Decimal(m) + Decimal(393.5), Decimal(scene.drag_b), Decimal(k)
        offset = damping * Decimal(u) / stiff
        root = (damping * damping - 4 * stiff * mass).sqrt()
        s1, s2 = (-damping + root) / (2 * mass), (-damping - root) / (2 * mass)
        a, b = -s2 * -offset / (s1 - s2), s1 * -offset / (s1 - s2)
        for i in range(1, 201):
            r = sim.advance(1e-3)
            t = Decimal(i) / 1000
            exact = offset + a * (s1 * t).exp() + b * (s2 * t).exp()
            assert abs(float(Decimal(r.x) - exact)) < 1e-16


def count_probes(monkeypatch, segment: type, limit: int, why: str) -> list[int]:
    """Count the calls of ``segment.probe`` (the root search's evaluations) into the returned
    one-element list, failing with ``why`` past ``limit`` (a search that walks without end)."""
    calls = [0]
    probe = segment.probe

    def counted(self, tau):
        calls[0] += 1
        assert calls[0] <= limit, why
        return probe(self, tau)
    monkeypatch.setattr(segment, "probe", counted)
    return calls

# --- a drifting ice at the lowest point of the envelope (method 1) -----------------------------

#: pi to 60 digits, for the exact impact times below
_PI = "3.14159265358979323846264338327950288419716939937510582097494459"

#: (flow / drag, ice velocity (m/s), ice's distance below the envelope's lowest point (m)):
#: coasting without drag, and at rest in a weak linear drag that pushes it downstream
DRIFTS = {
    "coasting at 1e-9 m/s": (dict(ice_Cd=0.0, flow_u=0.0), 1e-9, 5e-10),
    "coasting at 1e-13 m/s": (dict(ice_Cd=0.0, flow_u=0.0), 1e-13, 5e-14),
    "coasting at 1e-15 m/s": (dict(ice_Cd=0.0, flow_u=0.0), 1e-15, 5e-16),
    "at rest, linear drag, u = 1e-6 m/s": (dict(ice_Cd=1.0, drag_model=1, flow_u=1e-6), 0.0,
                                           1e-15),
    # turned back by the flow after 2 |w| / (kappa u) = 0.64 s (4.2e6 periods at 4.1e7 rad/s)
    "moving upstream at 1e-8 m/s, linear drag, u = 1e-6 m/s": (
        dict(ice_Cd=1.0, drag_model=1, flow_u=1e-6), -1e-8, 1e-15),
}


def _drifting(omega: float, flow: dict, w: float, below: float, swinging: bool) -> Simulator:
    """An undamped structure (m = M = 1600 kg, e = 1) swinging down to -0.16 m, released from
    rest there or (``swinging``) from its rest point at speed -0.16 omega_n; the ice ``below``
    m under the lowest point of its swing with velocity w."""
    start = dict(structure_x0=0.0, structure_v0=TANGENT_X0 * omega) if swinging else dict(
        structure_x0=TANGENT_X0, structure_v0=0.0)
    return Simulator(Scene(**{**dict(structure_m=1600.0, structure_k=1600.0 * omega ** 2,
                                     structure_c=0.0, **start, ice_M=1600.0,
                                     ice_z0=TANGENT_X0 - below, ice_v0=w, impact_e=1.0,
                                     solver_method=1), **flow}))


def _exact_first_impact(scene: Scene) -> tuple[float, float, float]:
    """Time (s), closing speed (m/s) and the ice's velocity (m/s) of the first impact, in
    60-digit decimal arithmetic from the scene's own numbers. The structure, released from rest
    at x0 or from 0 at speed v0 < 0, is at its lowest point L (x0, or v0 / omega_n) at every
    t_j = t_0 + j T (t_0 = 0 or T / 4); the ice (z0 + w0 t, or under the linear drag
    z0 + u t + (w0 - u)(1 - e^{-kappa t}) / kappa) moves downstream only, so the first trough
    it is past (z(t_j) > L, found by bisection over j) ends the first period the gap closes in
    (the earlier trough's dip, below (dz/dt)^2 / (2 omega_n^2 |L|) = 1e-33 m, is left out).
    Near it the gap is
    ``-d - w s + |L| omega_n^2 s^2 / 2`` (d = z(t_j) - L, w = dz/dt there; the next terms,
    (omega_n s)^4 |L| and z'' s^2, are below 1e-40 m), so it closes at its root s < 0, with
    closing speed sqrt(w^2 + 2 |L| omega_n^2 d)."""
    from decimal import Decimal, localcontext

    with localcontext() as ctx:
        ctx.prec = 60
        z0, w0 = Decimal(scene.ice_z0), Decimal(scene.ice_v0)
        omega = (Decimal(scene.structure_k) / Decimal(scene.structure_m)).sqrt()
        period = 2 * Decimal(_PI) / omega
        if scene.structure_v0 == 0.0:
            lowest, first = Decimal(scene.structure_x0), Decimal(0)
        else:
            assert scene.structure_x0 == 0.0 and scene.structure_v0 < 0.0
            lowest, first = Decimal(scene.structure_v0) / omega, period / 4
        if scene.ice_Cd == 0.0:
            def ice(t):
                return z0 + w0 * t, w0
        else:
            kappa, u = Decimal(scene.drag_b) / Decimal(scene.ice_M), Decimal(scene.flow_u)

            def ice(t):
                decay = (-kappa * t).exp()
                return z0 + u * t + (w0 - u) * (1 - decay) / kappa, u + (w0 - u) * decay
        lo, hi = -1, 1
        while ice(first + hi * period)[0] <= lowest:
            lo, hi = hi, 2 * hi
        while hi - lo > 1:
            mid = (lo + hi) // 2
            lo, hi = (lo, mid) if ice(first + mid * period)[0] > lowest else (mid, hi)
        t_j = first + hi * period
        z, w = ice(t_j)
        depth, curvature = z - lowest, -lowest * omega * omega
        closing = (w * w + 2 * curvature * depth).sqrt()
        return float(t_j + (w - closing) / curvature), float(closing), float(w)


@pytest.mark.parametrize("swinging", [False, True])
@pytest.mark.parametrize("omega", [4.1e5, 4.1e7])
@pytest.mark.parametrize("name", list(DRIFTS))
def test_a_drifting_ice_meets_the_envelope_exactly_in_bounded_work(name, omega, swinging,
                                                                  monkeypatch):
    """The ice drifting downstream into the lowest point of an undamped structure's swing: the
    gap's dip deepens by the ice's drift per period, w T (1.5e-16 m to 1.5e-22 m), so its
    first impact comes after up to 1e7 periods at the bottom of the envelope. The root search
    walked those period by period (6.6e6 periods a second at omega_n = 4.1e7 rad/s, one
    simulated second of the ice at 1e-15 m/s did not finish in 5 s of CPU), and took a graze
    within its time resolution for a touch, then the structure's speed there for a closing
    speed: impacts up to 1.9e4 periods early, where the gap was still open by 2e-16 m. The
    periods the ice has not yet reached are now proven free by bisection over the periods
    (``Flight._drift_clearance``): a few hundred evaluations of the closed forms, whatever
    omega_n and the drift. The impact is the exact one (60-digit decimal arithmetic, above),
    to the search's time resolution."""
    flow, w, below = DRIFTS[name]
    sim = _drifting(omega, flow, w, below, swinging)
    calls = count_probes(monkeypatch, Flight, 10_000, "period by period")
    while sim.impact_count == 0:
        sim.advance(0.01)
        assert sim.t < 2.0
    assert calls[0] <= 300
    hit = sim.impacts[0]
    t_exact, closing, drift = _exact_first_impact(sim.scene)
    resolution = 8.9e-16 * (1.0 + t_exact)  # the search's time resolution there
    # and the rounding of the structure's lowest point: exact released from rest (x0 + x0 (C - 1)
    # at C = -1), 1.7e-17 m off through its rest point (v0 S / omega_n), 2.8e-17 m (one ulp of
    # 0.16) per 1e-15 m/s of drift is 0.028 s
    rounding = 0.0 if swinging is False else math.ulp(TANGENT_X0)
    assert abs(hit.t - t_exact) <= 2.0 * resolution + rounding / drift
    # the closing speed to what those give: the structure's speed changes by its curvature
    # omega_n^2 |x0| times the time (0.48 m/s over 1.8e-15 s at omega_n = 4.1e7), and a dip
    # deeper by the rounding closes at sqrt(2 curvature rounding)
    curvature = omega ** 2 * abs(TANGENT_X0)
    assert abs((hit.w_minus - hit.v_minus) - closing) <= (curvature * 2.0 * resolution
                                                          + math.sqrt(2.0 * curvature * rounding))


def test_an_ice_stopping_short_of_the_envelope_is_proven_clear_at_once(monkeypatch):
    """The ice coasting into the envelope's lowest point at 1e-12 m/s under a linear drag and no
    flow: it stops 5e-16 m short (z0 + w0 / kappa), within the rounding the envelope's margin
    allows, so no impact ever (exact: the ice never passes the structure's lowest point, which
    the structure released from rest there reaches exactly). The root search walked the
    grazes period by period, forever; the period search now proves the future up to
    omega_n t = 2^46 (1.7e6 s) free at once."""
    scene = Scene(structure_m=1600.0, structure_k=1600.0 * TANGENT_OMEGA ** 2,
                  structure_c=0.0, structure_x0=TANGENT_X0, structure_v0=0.0, ice_M=1600.0,
                  ice_Cd=1.0, drag_model=1, flow_u=0.0, ice_z0=TANGENT_X0 - 1e-15,
                  impact_e=1.0, solver_method=1)
    kappa = scene.drag_b / scene.ice_M
    sim = Simulator(Scene(**{**scene.__dict__, "ice_v0": 5e-16 * kappa}))
    from decimal import Decimal
    stop = Decimal(sim.scene.ice_z0) + Decimal(sim.scene.ice_v0) / (
        Decimal(sim.scene.drag_b) / Decimal(sim.scene.ice_M))
    assert stop < Decimal(TANGENT_X0)
    calls = count_probes(monkeypatch, Flight, 10_000, "period by period")
    for _ in range(100):
        r = sim.advance(0.01)
        assert r.gap >= 0.0 and r.impulse == 0.0
    assert sim.impact_count == 0
    assert calls[0] <= 300
    assert sim.solver.seg.search.a >= 1e4  # its frontier, s


# --- a well over-damped sticking phase decaying to rest (method 1, linear drag) ---------------

def _decimal_sticking_impulses(scene: Scene, x0: float, v0: float, u: float, h: float,
                               steps: int) -> list:
    """Each step's contact impulse of a linear-drag sticking phase from its anchor (x0, v0) at
    t = 0, from the closed form in 60-digit decimal arithmetic (mass m + M, damping c + b,
    equilibrium b u / k, the over-damped motion on its two exponents), as the ice's momentum
    balance over the step: the drag impulse b (u dt - dx) minus M dv."""
    from decimal import Decimal, localcontext
    with localcontext() as ctx:
        ctx.prec = 60
        b = Decimal(scene.drag_b)
        mass = Decimal(scene.structure_m) + Decimal(scene.ice_M)
        damping, stiff = Decimal(scene.structure_c) + b, Decimal(scene.structure_k)
        offset = b * Decimal(u) / stiff
        root = (damping * damping - 4 * stiff * mass).sqrt()
        s1, s2 = (-damping + root) / (2 * mass), (-damping - root) / (2 * mass)
        y0, w0 = Decimal(x0) - offset, Decimal(v0)
        a, c = (w0 - s2 * y0) / (s1 - s2), (s1 * y0 - w0) / (s1 - s2)

        def state(t):
            e1, e2 = (s1 * t).exp(), (s2 * t).exp()
            return a * e1 + c * e2, a * s1 * e1 + c * s2 * e2
        out, (y_a, v_a) = [], state(Decimal(0))
        for i in range(1, steps + 1):
            y_b, v_b = state(Decimal(i) * Decimal(h))
            out.append(b * (Decimal(u) * Decimal(h) - (y_b - y_a))
                       - Decimal(scene.ice_M) * (v_b - v_a))
            y_a, v_a = y_b, v_b
        return out


def test_a_decaying_over_damped_sticking_phase_gives_its_exact_small_impulses():
    """Method 1, linear drag, an over-damped pair sticking (m = 0.6 kg, c = 9.1e6 N.s/m,
    k = 1.4e10 N/m, M = 18 mg: zeta 50 together, no flow to speak of) decaying from 0.19 m/s.
    Each step's impulse was the integral from the anchor's force, lam0 dt plus that of
    q - q0, with the rounding of lam0 dt: by t = 0.014 s steps of 3e-14, 1.4e-13 and
    -8.3e-14 N.s (tensile) for a true 6e-20. The step's momentum balance on its own modes has
    a rounding that decays with the motion: each step now matches the closed form in decimal
    arithmetic (and is >= 0)."""
    v0 = 0.18913741007012352
    scene = Scene(structure_m=0.6026885668330727, structure_c=9059994.330384696,
                  structure_k=13919009506.926985, structure_x0=0.0, structure_v0=v0,
                  ice_M=0.01847137342471947, ice_A=122.97055369620666,
                  ice_Cd=0.5921239351774049, ice_z0=0.0, ice_v0=v0, impact_e=0.0,
                  drag_model=1, flow_u=-2.6161706687673503e-45, solver_method=1)
    sim = Simulator(scene)
    h, steps = 1e-4, 300
    exact = _decimal_sticking_impulses(scene, 0.0, v0, scene.flow_u, h, steps)
    for i in range(steps):
        r = sim.advance(h)
        assert r.sticking and r.impulse >= 0.0
        assert abs(float(exact[i]) - r.impulse) <= 1e-9 * float(exact[i]), i


def test_a_pair_sticking_to_rest_without_flow_keeps_exact_impulses_in_bounded_work(monkeypatch):
    """Method 1, linear drag, a 29 mg pair (k = 5.6e8 N/m, b = 1.5e4 kg/s) sticking from
    0.24 m with no flow: it is at rest (positions and speeds underflowed) by t = 0.03 s. The
    impulses from the anchor's force came out as +-2.3e-10 N.s per 0.01 s step (one ulp of
    lam0 dt), alternately tensile, and the contact force lam0 + (q - q0) as its rounding,
    1.5e-8 N, along which the separation search crawled, 2e4 steps per 0.01 s. Each step's
    impulse now matches the closed form in decimal arithmetic (>= 0, 0 at rest), and the
    force's two modes prove it compressive for ever (Q1 >= 0, Q1 + Q2 >= 0, no flow)."""
    x0, v0 = 0.24483121483815284, 0.09148875304197258
    scene = Scene(structure_m=2.929723032384046e-05, structure_c=0.0,
                  structure_k=555219947.5965517, structure_x0=x0, structure_v0=v0,
                  ice_M=2.929723032384046e-05, ice_A=208.22135853441782,
                  ice_Cd=0.14689286517096625, ice_z0=x0, ice_v0=v0, impact_e=0.09,
                  drag_model=1, flow_u=0.0, solver_method=1)
    calls = count_probes(monkeypatch, LinearStick, 20_000,
                         "the search crawls along the force's rounding")
    sim = Simulator(scene)
    h, steps = 0.01, 300
    exact = _decimal_sticking_impulses(scene, x0, v0, 0.0, h, steps)
    for i in range(steps):
        r = sim.advance(h)
        assert r.sticking and r.impulse >= 0.0
        assert abs(float(exact[i]) - r.impulse) <= 1e-9 * float(exact[i]) + 1e-300, i
    assert r.v == 0.0 and abs(r.x) <= 2.0 ** -52 * x0  # at rest, to the rounding of x0 + dx
    assert calls[0] <= 1_000


def test_a_pair_at_rest_stays_at_rest_when_the_flow_stops():
    """Method 1, linear drag: a pair at rest in contact (m = 6364 kg, k = 0.64 N/m, M = 80 kg,
    b = 1.2e5 kg/s: zeta 1.2e3 together), sticking under a flow of 1.7 m/s (equilibrium
    4,300 m away) that the first step sets to 0. The re-anchor took the sticking phase's
    velocity at its anchor from its two modes, A s1 + B s2, terms of 0.4 m/s each: 2.2e-16 m/s
    instead of 0, and a flight from that speed created energy from rest (1.6e-28 J by 3 s).
    The velocity is now v0 plus its increments while the fast mode is above half its start:
    exactly v0 at the anchor; nothing moves."""
    scene = Scene(structure_m=6364.4498697548715, structure_c=0.0,
                  structure_k=0.6364449869754872, ice_M=79.80895101228585,
                  ice_A=138.443389909025, ice_Cd=1.7117864047293625, ice_z0=0.0, ice_v0=0.0,
                  impact_e=0.0, drag_model=1, drag_v_lin=0.013438131022709217,
                  flow_u=1.7117864047293625, solver_method=1)
    sim = Simulator(scene)
    for _ in range(3):
        r = sim.advance(1.0, 0.0)
        assert (r.x, r.v, r.z, r.w, r.impulse) == (0.0, 0.0, 0.0, 0.0, 0.0)


def test_a_well_over_damped_response_starts_at_its_anchor_exactly():
    """The two-mode form of a well over-damped response (:meth:`Oscillator.increment`) gives
    the anchor's velocity exactly at t = 0, however far the equilibrium (A s1 + B s2 missed
    v0 = 0 by 2.2e-16 m/s at 4,300 m), scalar and vectorised alike, and near t = 0 matches
    the closed form in decimal arithmetic."""
    from decimal import Decimal, localcontext
    mass, damping, stiff = 6444.258820767157, 1590.728863692959, 0.6364449869754872
    osc = Oscillator(mass, damping, stiff, offset=4278.434268797329)
    assert osc.two_modes
    for x0, v0 in ((0.0, 0.0), (0.0, 1e-300), (3.0, -2.5e-3), (-1e6, 7.0)):
        assert osc.increment(x0, v0)(0.0) == (0.0, v0)
        dx, v = osc.displacement_change_array(x0, v0, np.array([0.0]))
        assert (dx[0], v[0]) == (0.0, v0)
    with localcontext() as ctx:
        ctx.prec = 50
        m_, c_, k_ = Decimal(mass), Decimal(damping), Decimal(stiff)
        root = (c_ * c_ - 4 * k_ * m_).sqrt()
        s1, s2 = (-c_ + root) / (2 * m_), (-c_ - root) / (2 * m_)
        y0 = -Decimal(osc.offset)
        a, b = -s2 * y0 / (s1 - s2), s1 * y0 / (s1 - s2)
        for t in (1e-6, 1e-3, 0.1, 10.0):
            exact = a * s1 * (s1 * Decimal(t)).exp() + b * s2 * (s2 * Decimal(t)).exp()
            v = osc.increment(0.0, 0.0)(t)[1]
            assert abs(float(Decimal(v) - exact)) <= 4e-16 * abs(float(exact)), t
            assert osc.displacement_change_array(0.0, 0.0, np.array([t]))[1][0] == v


# --- a heavy ice the flow turns back, next to a stiff structure's envelope (method 1) ----------

#: The random search's TIMEOUT (method 1, seed 12): a stiff undamped pair (omega_n 5.6e7 rad/s)
#: released from rest at its lowest point -0.57 m, where the heavy ice (M = 3.4e11 kg, linear
#: drag) starts at rest, the flow of 3340 m/s reversed at every 0.37 s step.
HEAVY_ICE = dict(structure_m=1e9, structure_c=0.0, structure_k=3.11296231733161e+24,
                 structure_x0=-0.5663221133377271, ice_M=336172133760.24585,
                 ice_Cd=0.9616590278639208, ice_z0=-0.5663221133377271, ice_v0=0.0,
                 drag_model=1, drag_v_lin=1.0, flow_u=-3339.8447649555183, solver_method=1)


@pytest.mark.parametrize("e", [0.0, 1.0])
def test_a_heavy_ice_the_flow_turns_back_is_proven_clear_of_a_stiff_envelope(e, monkeypatch):
    """The first step's flow carries the ice upstream (to -1.8e-6 m/s, 3e-7 m below the
    structure's lowest point), the second turns it back: the ice's downstream speed bound is
    then the flow's 3340 m/s, and the envelope's margin over it (``Flight.clearance``) proved
    1e-10 s at a time, a thousandth of a period, so the root search walked the 2e7 periods of
    the step (no 0.37 s step in 10 s of CPU). The ice's acceleration bound (4.8e-6 m/s^2) now
    proves the whole step at once. Exact answer: the ice's velocity is monotone within each
    step (it relaxes towards +-u), so the ice is furthest downstream at a step's start or end,
    and every step ends with it upstream of z0, the structure's lowest point: no impact, the
    structure rings freely (x0 cos omega_n t) and the gap stays >= 0."""
    scene = Scene(**HEAVY_ICE, impact_e=e)
    sim = Simulator(scene)
    calls = count_probes(monkeypatch, Flight, 10_000, "period by period")
    omega = math.sqrt(scene.structure_k / scene.structure_m)
    x0 = scene.structure_x0
    for i in range(8):  # 2.96 s
        r = sim.advance(0.37, scene.flow_u if i % 2 == 0 else -scene.flow_u)
        assert r.z < scene.ice_z0  # the exact answer's premise (above)
        assert r.gap >= 0.0 and r.impulse == 0.0 and sim.impact_count == 0
        # free ringing, to the rounding of the phase omega_n t (2e7 rad per step)
        phase_rounding = 4.0 * omega * r.t * 2.0 ** -53 * abs(x0)
        assert abs(r.x - x0 * math.cos(omega * r.t)) <= 2.0 * phase_rounding
        assert abs(r.v + x0 * omega * math.sin(omega * r.t)) <= 2.0 * omega * phase_rounding
    assert calls[0] <= 100  # a few probes a step, however many periods


def test_the_search_tells_a_run_busy_with_impacts_from_a_stall():
    """A run out of CPU time counts as busy, not as a TIMEOUT fault, only if its impacts keep
    within one per chatter time and it spent at most IMPACT_WORK s of CPU per impact, over the
    whole run and over its second half (a run stalled after many quick impacts is a fault)."""
    from iceimpact.solvers.contact_rules import chatter_time
    from random_search import IMPACT_WORK, busy_with_impacts

    scene = Scene(**ELASTIC_CHATTER)
    t = 0.5
    cap = 2 * int(t / chatter_time(1e4) / 2)  # even: the second half has cap / 2 of them
    work, half = IMPACT_WORK * cap, cap // 2
    assert busy_with_impacts(scene, t, cap, work, half, work / 2)
    assert not busy_with_impacts(scene, t, 2 * cap + 2, work, half, work / 2)  # too many
    assert not busy_with_impacts(scene, t, cap, 2 * work, half, work / 2)  # too slow
    assert not busy_with_impacts(scene, t, cap, work, 0, work / 2)  # stalled late
    assert not busy_with_impacts(scene, t, cap, work, 10, work / 2)  # nearly stalled late
    assert not busy_with_impacts(scene, 0.0, 0, 0.0, 0, 0.0)


def test_a_slow_mode_far_below_the_fast_one_still_parts_the_bodies():
    """Method 1, linear drag, well over-damped sticking (the search with seed 48): a plastic
    impact at 0.17 m/s sticks a 0.8 mg floe to a 0.45 g structure (omega_n 1e-3 rad/s) under
    b = 217 kg/s, no flow. The fast mode (4.8e5 1/s) starts at 36 N of contact force; the
    slow one, the spring pulling the pair back against the floe's drag, is a tension of
    -1.6e-16 N, which the modes of the anchor's (q0, q0') gave as exactly 0: the bodies were
    never parted and every 0.1 ms step had an impulse of -1.6e-20 N.s. The force's modes now
    come from the deviation's (``Qk = -sk (b + M sk) Yk``): the bodies part where the two
    modes balance, at the time a 50-digit closed form gives, and no step pulls."""
    from decimal import Decimal, localcontext

    scene = Scene(structure_m=0.00045338246088430967, structure_c=0.0,
                  structure_k=4.533824608843097e-10, structure_x0=0.0,
                  structure_v0=-0.1663099506821799, ice_M=7.895833311786706e-07, ice_A=1.0,
                  ice_Cd=0.7718513369004822, ice_z0=0.0, ice_v0=7.589709039162833e-05,
                  impact_e=0.0, drag_model=1, drag_v_lin=0.5630380684168985, flow_u=0.0,
                  solver_method=1)
    sim = Simulator(scene)
    r = sim.advance(1e-4, 0.0)
    assert not r.sticking and sim.impact_count == 1
    impact = sim.impacts[0]
    parted = sim.solver.seg.t0  # the flight from the separation
    with localcontext() as ctx:
        ctx.prec = 50
        mass = Decimal(scene.structure_m) + Decimal(scene.ice_M)
        b = Decimal(scene.drag_b)
        k, M = Decimal(scene.structure_k), Decimal(scene.ice_M)
        root = (b * b - 4 * mass * k).sqrt()
        s1, s2 = (-b + root) / (2 * mass), (-b - root) / (2 * mass)
        v0 = Decimal(impact.v_plus)  # from x = 0, no flow: y0 = 0
        y1, y2 = v0 / (s1 - s2), -v0 / (s1 - s2)
        q1, q2 = -s1 * (b + M * s1) * y1, -s2 * (b + M * s2) * y2
        assert q1 < 0 < q2  # the slow mode pulls, the fast one pushes
        exact = float((-q2 / q1).ln() / (s1 - s2))
    assert parted == pytest.approx(exact, rel=1e-9)
    for _ in range(20):
        r = sim.advance(1e-4, 0.0)
        assert r.impulse >= 0.0 and not r.sticking
        assert sim.solver.state.x >= sim.solver.state.z


def test_the_search_tells_a_run_busy_integrating_at_its_rate_from_a_stall():
    """Method 3 at its explicit rate limit costs up to ~10 s of CPU per simulated second by its
    rate rule (the seed-53 search's damped 26 g structure, c / m = 2.7e5 1/s: 3.8 rate
    evaluations per simulated second, 9.9 s for its second). A run out of CPU time counts as
    busy, not as a TIMEOUT fault, while its evaluations keep within ODE_WORK of them per unit
    rate and simulated second (plus ODE_RESTART_WORK per step and ODE_WORK_FLOOR); beyond,
    and for the other methods or an implicit integrator, it is a fault."""
    from iceimpact.limits import integrated_rate
    from random_search import ODE_RESTART_WORK, ODE_WORK, ODE_WORK_FLOOR, busy_integrating

    scene = Scene(structure_m=0.026356702073031105, structure_c=7106.487429949025,
                  structure_k=2082983.3397196622, ice_M=8.48189216315647e-06, ice_Cd=0.0,
                  ice_z0=-0.04, impact_e=0.0, solver_method=3)
    rate = integrated_rate(scene, 0.1)
    assert rate == pytest.approx(2.7e5, rel=0.01)
    allowed = ODE_WORK * rate * 0.5 + ODE_RESTART_WORK * 50 + ODE_WORK_FLOOR
    assert busy_integrating(scene, 0.1, 0.5, int(allowed), 50)
    assert not busy_integrating(scene, 0.1, 0.5, int(allowed) + 1, 50)
    assert not busy_integrating(scene, 0.1, 0.0, 0, 0)
    assert not busy_integrating(scene.replace(solver_ode_method=3), 0.1, 0.5, 10, 50)  # LSODA
    assert not busy_integrating(scene.replace(solver_method=1), 0.1, 0.5, 10, 50)


def test_method_3_sees_a_meeting_hidden_inside_one_integrator_step():
    """Fix 33 (the search with seed 57): a light ice (0.59 kg, quadratic drag) following a slow
    structure, the flow reversed by random signs at 1 ms steps. DOP853 crossed a 3.5 ms dip of
    the gap below zero in one 4 ms step, whose ends both had an open gap: solve_ivp tests the
    event's sign at step ends only, so the ice went 2.5e-7 m through the structure with no
    impact. The dip's lowest point is where the gap's rate turns from closing to opening inside
    a step; the meeting is now found there on the dense output, and the impacts are those of
    the exact method, which shares no integration with it (its own no-miss root search)."""
    case = {"scene": dict(structure_m=0.5900798482397783, structure_c=8.186006944808163e-39,
                          structure_k=0.20546239680237188, structure_x0=-0.01,
                          structure_v0=-0.6095437618432101, ice_M=0.5902157347899184,
                          ice_A=0.5900798482397783, ice_Cd=0.1500251476655752, ice_z0=-0.01,
                          ice_v0=0.0, impact_e=0.02438189881828224, drag_model=2,
                          drag_v_lin=0.01, flow_u=0.0, solver_method=3),
            "h": 0.001, "flow": "random signs",
            "signs": [False, False, False, True, False, False, False, False, False]}
    from random_search import flow_at, replay

    outcome = replay(case)
    assert outcome.fault is None and outcome.min_gap >= 0.0
    runs = {}
    for method in (1, 3):
        sim = Simulator(Scene(**{**case["scene"], "solver_method": method}))
        k, lowest = 0, math.inf
        while sim.t < 0.8 - 1e-12:
            sim.advance(case["h"], flow_at(case["flow"], k, 0.1, case["signs"]))
            k += 1
            lowest = min(lowest, sim.solver.state.gap)
        runs[method] = ([i.t for i in sim.impacts], lowest)
    exact, ode = runs[1][0], runs[3][0]
    assert len(ode) == len(exact) == 55
    assert max(abs(a - b) for a, b in zip(exact, ode, strict=True)) < 1e-6
    assert 0.7903 < ode[-2] < 0.7904  # the meeting inside the step [0.790, 0.794]
    assert runs[3][1] >= -1e-10


def test_method_3_sees_a_tensile_moment_hidden_inside_one_integrator_step():
    """Fix 33, sticking: the seed-49 scene at omega_n 1.7e3 rad/s (k / 1e8), a plastic ice
    stuck on an undamped structure and ringing just beyond what its drag holds. Its contact
    force turns tensile for a short moment each period, shorter than DOP853's steps: tested at
    step ends only, the bodies were held through it (a pull) and method 3 made 10, 4 and 1
    impacts in the windows where the exact method makes 24, 23 and 7. The contact force's
    lowest point inside a step, where its rate (``Together.contact_force_rate``) turns from
    negative to positive, is now checked: every 0.1 s window has the exact method's impacts,
    and the ringing the same amplitude, to 1e-3 of the drag's threshold."""
    from test_step_budget import SEED_49

    windows = {}
    for method in (1, 3):
        scene = Scene(**{**SEED_49, "structure_k": SEED_49["structure_k"] / 1e8,
                         "solver_method": method})
        sim = Simulator(scene)
        counts, states = [], []
        for _ in range(6):
            before = sim.impact_count
            r = sim.advance(0.1, 0.1)
            assert r.impulse >= 0.0
            counts.append(sim.impact_count - before)
            states.append(sim.solver.state)
        windows[method] = counts, states
    assert windows[3][0] == windows[1][0] == [23, 23, 24, 23, 7, 0]
    # the pair's largest ringing its drag holds, x_eq (m + M) / M with x_eq = b u / k (m)
    scale = (scene.drag_b * 0.1 / scene.structure_k
             * (scene.structure_m + scene.ice_M) / scene.ice_M)
    for exact, ode in zip(windows[1][1], windows[3][1], strict=True):
        assert abs(exact.x - ode.x) < 1e-3 * scale


@pytest.mark.parametrize("drag_model", [1, 2], ids=["linear", "quadratic"])
@pytest.mark.parametrize("morison", [False, True], ids=["plain", "morison"])
def test_the_contact_force_rate_is_the_derivative_of_the_contact_force(drag_model, morison):
    """``Together.contact_force_rate`` (fix 33's look inside method 3's sticking steps) against
    a central difference of ``contact_force`` along the sticking motion, for both drag laws,
    with and without the Morison drag on the structure; arrays element by element."""
    from iceimpact.solvers.contact_rules import make_together
    from iceimpact.solvers.ode import OdeSolver

    extra = {"structure_Cd": 1.0, "structure_A": 2.0} if morison else {}
    scene = Scene(drag_model=drag_model, solver_method=3, **extra)
    solver = OdeSolver(scene)
    together = make_together(solver.m, solver.c, solver.k, solver.M, solver.drag, 0.3,
                             inertia_from_net=True, structure_drag=solver.structure_drag)
    states = np.array([[0.01, -0.02, 0.0], [-0.003, 0.4, 1.0], [0.0, 0.3, 0.0]]).T
    rates = together.contact_force_rate(states)
    for k in range(states.shape[1]):
        y = states[:, k]
        dy = np.array(together(0.0, y))
        delta = 1e-6
        numeric = (together.contact_force(y + delta * dy)
                   - together.contact_force(y - delta * dy)) / (2 * delta)
        assert rates[k] == pytest.approx(numeric, rel=1e-6, abs=1e-9)
        assert together.contact_force_rate(y) == pytest.approx(rates[k], rel=1e-15)
