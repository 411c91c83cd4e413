"""An independent integration of the model with scipy ``solve_ivp``: the check on the exact solver.

Shares no code with ``iceimpact``: the equations of motion (eq. 3-4, 8, with the Morison added
mass and drag on the structure when a scene asks for them), the impact law (eq. 16-17, the added
mass moving with the structure) and the gap event are written out again here. Used by the tests
(DOP853, rtol 1e-12) and as the speed baseline of ``benchmarks/core_speed.py`` (rtol 1e-10). It
stops at the first impact that would start a Zeno sequence (closing speed below ``min_closing``),
which it cannot handle.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp


def simulate(scene, t_end: float, max_impacts: int = 10**9, rtol: float = 1e-12,
             atol: float = 1e-15, method: str = "DOP853", min_closing: float = 1e-9,
             t0: float = 0.0, y0=None):
    """Impact times and pre/post velocities from a direct ODE integration with gap events.

    Returns a dict with arrays ``t``, ``x``, ``v_minus``, ``w_minus``, ``v_plus``, ``w_plus``,
    ``approach`` and the count of right-hand-side evaluations ``nfev``. ``t0`` and ``y0``
    (x, v, z, w) start it from another state than the scene's initial one.
    """
    rho = scene.fluid_rho
    # the added mass rho Ca V moves with the structure (docs/explanation/morison.md)
    m = scene.structure_m + rho * scene.structure_Ca * scene.structure_V
    c, k = scene.structure_c, scene.structure_k
    M, e, u = scene.ice_M, scene.impact_e, scene.flow_u
    B = 0.5 * rho * scene.ice_Cd * scene.ice_A
    b = B * scene.drag_v_lin
    B_s = 0.5 * rho * scene.structure_Cd * scene.structure_A  # drag on the structure
    b_s = B_s * scene.drag_v_lin
    quadratic = scene.drag_model == 2

    def rhs(t, y):
        x, v, z, w = y
        r = w - u
        drag = -B * abs(r) * r if quadratic else -b * r
        return [v, -(c * v + k * x) / m, w, drag / M]

    if B_s > 0.0:
        def rhs(t, y):  # noqa: F811 (the flow drags the structure too)
            x, v, z, w = y
            r, r_s = w - u, u - v
            drag = -B * abs(r) * r if quadratic else -b * r
            drag_s = B_s * abs(r_s) * r_s if quadratic else b_s * r_s
            return [v, (drag_s - c * v - k * x) / m, w, drag / M]

    def gap(t, y):
        return y[0] - y[2]

    gap.terminal = True
    gap.direction = -1

    if y0 is None:
        y0 = [scene.structure_x0, scene.structure_v0, scene.ice_z0, scene.ice_v0]
    y = np.array(y0, float)
    t = float(t0)
    rows = []
    nfev = 0
    while t < t_end and len(rows) < max_impacts:
        # a short first step: solve_ivp sees no crossing in a step that starts at gap = 0, so a
        # whole bounce inside the first step would be missed
        sol = solve_ivp(rhs, (t, t_end), y, method=method, rtol=rtol, atol=atol, events=gap,
                        first_step=1e-7)
        nfev += sol.nfev
        if sol.status != 1 or not len(sol.t_events[0]):
            break
        t = float(sol.t_events[0][0])
        x, v, z, w = sol.y_events[0][0]
        approach = w - v
        if approach < min_closing:
            break
        # eq. 16-17
        v_plus = (m * v + M * w + e * M * (w - v)) / (m + M)
        w_plus = (m * v + M * w - e * m * (w - v)) / (m + M)
        rows.append((t, x, v, w, v_plus, w_plus, approach))
        y = np.array([x, v_plus, x, w_plus])
    arr = np.array(rows, dtype=float).reshape(-1, 7)
    names = ["t", "x", "v_minus", "w_minus", "v_plus", "w_plus", "approach"]
    out = {name: arr[:, i] for i, name in enumerate(names)}
    out["nfev"] = nfev
    return out
