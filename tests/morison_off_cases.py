"""Runs whose numbers must not change when the Morison terms on the structure are off.

``python tests/morison_off_cases.py OUT.json`` writes, for each case, the SHA-256 digest of every
number a run stepped through the :class:`iceimpact.Simulator` reports (states, impulses, impact
times and velocities, as exact hexadecimal floats), per quantity.
``tests/test_morison.py`` computes them with the four Morison parameters at their defaults and
with each product (Ca V, Cd A) zero while one factor is not, with every Morison entry point made to
raise, and asks for the same bits; ``benchmarks/morison_cost.py`` compares them with the tree
before the Morison terms existed, run side by side.
"""

from __future__ import annotations

import hashlib
import json
import sys

from iceimpact import Scene, Simulator

#: (name, scene changes, horizon s, communication step s, flow changes (from time s, u m/s)).
CASES = (
    ("figure 2, exact", {}, 20.0, 1e-2, ()),
    ("figure 2 e = 0.5, exact", {"impact_e": 0.5}, 20.0, 1e-2, ()),
    ("figure 13 quadratic, exact", {"drag_model": 2, "ice_A": 2.0}, 20.0, 1e-2, ()),
    ("quadratic e = 0.5, exact, flow reversing", {"drag_model": 2, "impact_e": 0.5}, 20.0, 1e-2,
     ((8.0, -0.1), (12.0, 0.3))),
    ("figure 2, fixed-step", {"solver_method": 2, "solver_detection": 1}, 5.0, 1e-2, ()),
    ("figure 2 e = 0.5, fixed-step, sign test",
     {"solver_method": 2, "solver_detection": 2, "impact_e": 0.5}, 5.0, 1e-2, ()),
    ("quadratic, fixed-step",
     {"solver_method": 2, "solver_detection": 1, "drag_model": 2}, 5.0, 1e-2, ()),
    ("figure 2, ODE", {"solver_method": 3}, 3.0, 1e-2, ()),
    ("quadratic e = 0.5, ODE", {"solver_method": 3, "drag_model": 2, "impact_e": 0.5}, 3.0,
     1e-2, ()),
)


def fingerprint(scene: Scene, t_end: float, h: float, flow) -> dict[str, str]:
    """Per quantity, the digest of every number a run reports (hexadecimal floats) and their
    count."""
    sim = Simulator(scene)
    plan = [(0.0, scene.flow_u), *flow]
    out: dict[str, list[str]] = {key: [] for key in ("x", "v", "z", "w", "impulse", "gap")}
    for k in range(round(t_end / h)):
        u = [u for since, u in plan if since <= k * h + 1e-12][-1]
        r = sim.advance(h, u)
        for key in out:
            out[key].append(float(getattr(r, key)).hex())
    for key in ("t", "v_minus", "w_minus", "v_plus", "w_plus", "impulse"):
        out[f"impact_{key}"] = [float(getattr(i, key)).hex() for i in sim.impacts]
    return {key: f"{len(values)} {hashlib.sha256(','.join(values).encode()).hexdigest()}"
            for key, values in out.items()}


def compute(extra: dict | None = None) -> dict[str, dict[str, str]]:
    """The fingerprints of all CASES, each scene with ``extra`` changes added."""
    return {name: fingerprint(Scene(**changes, **(extra or {})), t_end, h, flow)
            for name, changes, t_end, h, flow in CASES}


if __name__ == "__main__":
    with open(sys.argv[1], "w") as fh:
        json.dump(compute(), fh, indent=1)
        fh.write("\n")
