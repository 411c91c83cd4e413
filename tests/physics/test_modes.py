"""The modal structure's physics (physics/modes.py) and its parameters' validation: the effective
mass, the static stiffness at the contact point, the velocity jump of an impulse, the bounds over
a flight, the refusals."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from iceimpact import Scene
from iceimpact.errors import ParameterError
from iceimpact.physics.modes import Modes

TWO_MODES = ((4.0, 0.01, 1600.0, 1.0), (11.0, 0.02, 1600.0, 0.6))


def test_the_effective_mass_is_the_inverse_of_the_summed_flexibilities():
    modes = Modes(TWO_MODES)
    assert modes.effective_mass == pytest.approx(1.0 / (1.0 / 1600.0 + 0.36 / 1600.0), rel=1e-15)


def test_the_contact_stiffness_of_one_mode_with_phi_1_is_the_sdofs_k():
    """k_c = m omega^2 for one mode seen with phi = 1: Figure 2's k = 1e6 N/m (the default mode
    is the SDOF's), and m (2 pi f)^2 for another; the SDOF's is structure.k itself."""
    sdof = Scene()
    assert sdof.contact_stiffness == sdof.structure_k == 1.0e6
    assert Scene(structure_model=3).contact_stiffness == pytest.approx(1.0e6, rel=1e-15)
    one = Scene(structure_model=3, structure_mode1_f=2.5, structure_mode1_m=800.0)
    assert one.contact_stiffness == pytest.approx(800.0 * (5.0 * math.pi) ** 2, rel=1e-15)


def test_the_contact_stiffness_of_two_modes_is_their_static_flexibilities_summed():
    """k_c = k1 k2 / (phi1^2 k2 + phi2^2 k1) for two modes, k_i = m_i (2 pi f_i)^2: the force
    that holds the contact point at x statically is k_c x (phi's sign and the modes beyond
    structure.modes do not enter, a mode with phi = 0 adds nothing)."""
    two = dict(structure_model=3, structure_modes=2, structure_mode1_f=4.0,
               structure_mode2_f=11.0, structure_mode2_m=900.0, structure_mode2_phi=0.6)
    k1, k2 = 1600.0 * (8.0 * math.pi) ** 2, 900.0 * (22.0 * math.pi) ** 2
    k_c = k1 * k2 / (k2 + 0.36 * k1)
    assert Scene(**two).contact_stiffness == pytest.approx(k_c, rel=1e-14)
    assert Scene(**two | dict(structure_mode2_phi=-0.6)).contact_stiffness == \
        Scene(**two).contact_stiffness
    # mode 3 unseen (phi = 0), mode 4 not used
    assert Scene(**two | dict(structure_modes=3, structure_mode3_f=30.0, structure_mode3_phi=0.0,
                             structure_mode4_phi=5.0)).contact_stiffness == \
        Scene(**two).contact_stiffness
    # the force k_c x at the contact point deflects each mode statically by phi_k k_c x / k_k
    # (its generalized force over its stiffness), which put back at the contact point make x
    x, found = 0.01, Scene(**two).contact_stiffness
    q = [phi * found * x / k for phi, k in ((1.0, k1), (0.6, k2))]
    assert q[0] + 0.6 * q[1] == pytest.approx(x, rel=1e-14)


def test_an_impulse_moves_each_mode_by_phi_j_over_m_and_the_contact_point_by_j_over_m_eff():
    modes = Modes(TWO_MODES)
    p = [0.1, -0.2]
    impulse = 3.0  # N.s at the contact point
    dv = impulse / modes.effective_mass
    after = modes.velocity_change(p, dv)
    for k, (_, _, m, phi) in enumerate(TWO_MODES):
        assert after[k] - p[k] == pytest.approx(phi * impulse / m, rel=1e-14)
    _, v_before = modes.contact([0.0, 0.0], p)
    _, v_after = modes.contact([0.0, 0.0], after)
    assert v_after - v_before == pytest.approx(dv, rel=1e-14)


def _integrate(table, loads, q0, p0, t_end):
    """The free modes under held loads, integrated by DOP853 (independent of the closed forms)."""
    omegas = [2 * math.pi * f for f, _, _, _ in table]

    def rhs(t, y):
        n = len(table)
        out = np.empty_like(y)
        for k, ((_, zeta, _, _), omega) in enumerate(zip(table, omegas, strict=True)):
            q, p = y[k], y[n + k]
            out[k] = p
            out[n + k] = loads[k] / table[k][2] - 2 * zeta * omega * p - omega * omega * q
        return out
    t = np.linspace(0.0, t_end, 2001)
    sol = solve_ivp(rhs, (0.0, t_end), [*q0, *p0], method="DOP853", rtol=1e-12, atol=1e-15,
                    t_eval=t)
    return t, sol.y


@pytest.mark.parametrize("table", [TWO_MODES, ((2.0, 1.5, 900.0, 0.5), (7.0, 0.0, 400.0, -1.2)),
                                   ((3.0, 1.0, 100.0, 1.0), (30.0, 0.05, 50.0, 0.3))],
                         ids=["under-damped", "over-damped and undamped", "critical and stiff"])
def test_the_bounds_hold_over_a_flight_and_the_closed_forms_match_an_integration(table):
    loads = (150.0, -40.0)
    modes = Modes(table, loads)
    q0, p0 = [1e-3, -2e-4], [0.01, 0.03]
    t, y = _integrate(table, loads, q0, p0, 3.0)
    n = len(table)
    increments = [osc.increment(q, p) for osc, q, p in zip(modes.oscillators, q0, p0, strict=True)]
    for i in range(0, len(t), 50):
        for k in range(n):
            dq, pk = increments[k](t[i])
            assert q0[k] + dq == pytest.approx(y[k, i], abs=1e-12)
            assert pk == pytest.approx(y[n + k, i], abs=1e-11)
    # the contact point's acceleration and jerk never exceed the bounds from the start
    _, a_max, j_max = modes.bounds(0.0, q0, p0)
    accel = np.zeros_like(t)
    for k, (f, zeta, m, phi) in enumerate(table):
        omega = 2 * math.pi * f
        accel += phi * (loads[k] / m - 2 * zeta * omega * y[n + k] - omega * omega * y[k])
    assert np.max(np.abs(accel)) <= a_max * (1 + 1e-12)
    jerk = np.gradient(accel, t)
    assert np.max(np.abs(jerk[5:-5])) <= j_max * (1 + 1e-6)
    # and the envelope holds the contact point
    centre = sum(phi * off for (_, _, _, phi), off in zip(table, modes.offsets(0.0),
                                                        strict=True))
    reach = modes.reach(*modes.deviations(0.0, q0, p0))
    x = sum(phi * y[k] for k, (_, _, _, phi) in enumerate(table))
    assert np.max(np.abs(x - centre)) <= reach * (1 + 1e-12)


def _modal(**kw) -> dict:
    return dict(structure_model=3, **kw)


@pytest.mark.parametrize(("changes", "name", "allowed"), [
    (dict(structure_mode1_m=0.0), "structure.mode1.m", "> 0"),
    (dict(structure_mode1_f=-1.0), "structure.mode1.f", "> 0"),
    (dict(structure_mode1_zeta=-0.1), "structure.mode1.zeta", ">= 0"),
    (dict(structure_mode1_phi=0.0), "structure.mode1.phi", "no mode moves the contact point"),
    (dict(structure_modes=6), "structure.modes", "1 <= modes <= 5"),
    (dict(structure_modes=0), "structure.modes", "1 <= modes <= 5"),
    (dict(structure_mode1_m=1e-320), "1 / sum(structure.mode<k>.phi^2", "effective mass"),
    # k_c = 1 / sum(phi^2 / k_k) overflows (a stiff mode barely seen) or underflows to 0
    (dict(structure_mode1_phi=1e-150, structure_mode1_m=1.0, structure_mode1_f=3000.0),
     "1 / sum(structure.mode<k>.phi^2 / (structure.mode<k>.m", "static stiffness"),
    (dict(structure_mode1_m=1e-300, structure_mode1_f=1e-5),
     "1 / sum(structure.mode<k>.phi^2 / (structure.mode<k>.m", "static stiffness"),
    (dict(structure_Ca=1.0, structure_V=1.0), "structure.Ca", "not modelled"),
    (dict(ice_z0=0.01), "ice.z0", "sum phi q0"),
    (dict(structure_mode1_f=5e3), "2 pi structure.mode1.f", "<= 20000 1/s"),
])
def test_a_bad_modal_parameter_is_refused_naming_it(changes, name, allowed):
    with pytest.raises(ParameterError) as info:
        Scene(**_modal(**changes))
    message = str(info.value)
    assert name in message and allowed in message


def test_modes_not_used_are_not_validated_beyond_their_ranges_and_defaults_are_the_sdof():
    scene = Scene(structure_model=3)
    sdof = Scene()
    assert scene.effective_mass == sdof.structure_m
    assert scene.omega_n == pytest.approx(sdof.omega_n, rel=1e-15)
    assert scene.mode_table[0][:3] == pytest.approx(
        (sdof.omega_n / (2 * math.pi), sdof.zeta, sdof.structure_m), rel=1e-15)
