"""Reference runs whose every number is pinned to the bit: the safety net of restructuring.

``python tests/reference_digests.py [OUT.json]`` writes (default: tests/reference_digests.json),
for each case, the SHA-256 digest of every number the run reports, per quantity (states, impulses,
contact flags, impact times and velocities, as exact hexadecimal floats). The cases cover every
method, both drag laws, impacts and sticking, flow changes, the Morison terms, the external
structure, the modal structure under loads and ``run()``'s sampled path.
``tests/test_reference_digests.py`` recomputes them (with the compiled flight search where numba
is installed, and pure) and asks for the same bits: code moved or rewritten without a change of
behaviour passes, anything else fails. The numbers are the
same on every machine (any BLAS kernel, any numpy SIMD level: tests/test_machine_matrix.py).
Regenerate the file only for a change of behaviour that is meant, and say so in the commit.
"""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

from coupling_master import ExactSdof
from iceimpact import Scene, Simulator, run

STORED = Path(__file__).with_name("reference_digests.json")

#: Figure 13's scene: quadratic drag, A = 2 m2.
QUADRATIC = {"drag_model": 2, "ice_A": 2.0}
MORISON = {"structure_Ca": 1.0, "structure_V": 0.5, "structure_Cd": 1.2, "structure_A": 1.0}
HEAVY = {"drag_model": 2, "flow_u": 0.3, "ice_M": 4800.0, "impact_e": 0.3}
#: The modal structure: two modes seen at the contact point (structure.model = 3).
TWO_MODES = {"structure_model": 3, "structure_modes": 2, "structure_mode2_f": 11.0,
             "structure_mode2_zeta": 0.02, "structure_mode2_phi": 0.6, "drag_model": 2,
             "flow_u": 0.3, "ice_M": 1200.0}
#: The modal cases' loads on modes 1 and 2 (N), held from each time on (s).
MODE_LOADS = ((0.0, (0.0, 0.0)), (3.0, (600.0, -200.0)), (6.0, (0.0, 150.0)))

#: (name, kind, scene changes, horizon s, communication step s, flow changes (from s, u m/s)).
#: kind: "step" (Simulator.advance), "run" (run(), sampled), "external" (structure.model = 2,
#: coupled to an exact SDOF by a Gauss-Seidel loop), "modal" (structure.model = 3 stepped under
#: the loads of MODE_LOADS, its modes' q and q' digested too). Methods 1 and 2 only: their
#: numbers are the same on every machine (tests/test_machine_matrix.py). Method 3's integrators
#: (scipy) call BLAS, whose kernel differs by CPU: its runs are held to its error bound instead
#: (METHOD_3_CASES, tests/solvers/test_ode.py).
CASES = (
    ("method 1, figure 2", "step", {}, 20.0, 1e-2, ()),
    ("method 1, e = 0.5", "step", {"impact_e": 0.5}, 20.0, 1e-2, ()),
    ("method 1, plastic, sticking", "step", {"impact_e": 0.0}, 20.0, 1e-2, ()),
    ("method 1, quadratic", "step", QUADRATIC, 20.0, 1e-2, ()),
    ("method 1, quadratic e = 0.5, flow reversing", "step", {**QUADRATIC, "impact_e": 0.5}, 20.0,
     1e-2, ((8.0, -0.1), (12.0, 0.3))),
    ("method 1, heavy floe at 2 m/s", "step", {"ice_M": 16000.0, "flow_u": 2.0}, 10.0, 1e-2, ()),
    ("method 1, over-damped structure", "step", {"structure_c": 1.0e5, "impact_e": 0.6}, 10.0,
     1e-2, ()),
    ("method 1, Morison linearised", "step", {**MORISON, "impact_e": 0.5}, 10.0, 1e-2, ()),
    ("method 1, Morison quadratic", "step", {**MORISON, **QUADRATIC, "impact_e": 0.5}, 10.0, 1e-2,
     ()),
    ("method 1, run() figure 2", "run", {}, 20.0, 1e-2, ()),
    ("method 1, run() plastic quadratic", "run", {**QUADRATIC, "impact_e": 0.0}, 20.0, 1e-2, ()),
    ("method 2, sign test", "step", {"solver_method": 2, "solver_detection": 2}, 5.0, 1e-2, ()),
    ("method 2, window", "step", {"solver_method": 2, "solver_detection": 1, "impact_e": 0.5},
     5.0, 1e-2, ()),
    ("method 2, quadratic", "step", {"solver_method": 2, "solver_detection": 2, **QUADRATIC}, 5.0,
     1e-2, ()),
    ("method 2, run()", "run", {"solver_method": 2, "solver_detection": 2}, 5.0, 1e-2, ()),
    ("external, Gauss-Seidel", "external", {**HEAVY, "coupling_scheme": 1}, 2.0, 1e-3, ()),
    ("external, Jacobi", "external", {**HEAVY, "coupling_scheme": 2}, 2.0, 1e-3, ()),
    ("modal, two modes e = 0.7, loads", "modal", {**TWO_MODES, "impact_e": 0.7}, 10.0, 1e-2,
     ()),
    ("modal, two modes plastic, riding, loads", "modal", {**TWO_MODES, "impact_e": 0.0}, 10.0,
     1e-2, ((5.0, 0.1),)),
    ("modal, run() two modes", "run", {**TWO_MODES, "impact_e": 0.7}, 10.0, 1e-2, ()),
    # the structure's flight under the quadratic Morison drag through reversals of u - x', one
    # of them a touch of 0 (its step from u - x' = 0 once ended where it began)
    ("method 1, Morison quadratic, relative flow reversing", "run",
     {"structure_Cd": 1.0, "structure_A": 2.0, "drag_model": 2, "structure_v0": 0.5,
      "ice_A": 2.0}, 20.0, 1e-2, ()),
)

#: Method 3's reference runs, in CASES' form (compared with method 1 within its error bound).
METHOD_3_CASES = (
    ("method 3, figure 2", "step", {"solver_method": 3}, 3.0, 1e-2, ()),
    ("method 3, quadratic e = 0.5", "step", {"solver_method": 3, **QUADRATIC, "impact_e": 0.5},
     3.0, 1e-2, ()),
    ("method 3, plastic, sticking", "step", {"solver_method": 3, "impact_e": 0.0}, 5.0, 1e-2,
     ((3.0, 0.05),)),
    ("method 3, Radau", "step", {"solver_method": 3, "solver_ode_method": 4}, 2.0, 1e-2, ()),
    ("method 3, Morison quadratic", "step", {"solver_method": 3, **MORISON, **QUADRATIC}, 2.0,
     1e-2, ()),
    ("method 3, run()", "run", {"solver_method": 3, "impact_e": 0.5}, 3.0, 1e-2, ()),
)

_REPORTED = ("t", "x", "v", "z", "w", "impulse", "gap", "penetration", "sticking", "impacts",
             "t_last", "spring_force", "coupling_force")
_IMPACT = ("t", "v_minus", "w_minus", "v_plus", "w_plus", "impulse")
#: What the modal cases report besides _REPORTED (the modes used: 1 and 2).
_MODAL = ("mode1_q", "mode1_v", "mode2_q", "mode2_v")


def _digest(values: list[str]) -> str:
    return f"{len(values)} {hashlib.sha256(','.join(values).encode()).hexdigest()}"


def _number(value) -> str:
    return float(value).hex()


def stepped(scene: Scene, kind: str, t_end: float, h: float, flow) -> tuple[Simulator, list]:
    """A "step", "external" or "modal" case stepped as the FMU steps it: the simulator and the
    report of every communication step (the flow held from each change of ``flow`` on; the
    external structure Figure 2's, stepped exactly under the force the ice gave it, Gauss-Seidel;
    the modal one under the loads of MODE_LOADS)."""
    if kind == "external":
        scene = scene.replace(structure_model=2)
    sim = Simulator(scene)
    plan = [(0.0, scene.flow_u), *flow]
    structure = ExactSdof(1600.0, 200.0, 1.0e6) if kind == "external" else None
    force = 0.0
    reports = []
    for k in range(round(t_end / h)):
        t = k * h
        u = [u for since, u in plan if since <= t + 1e-12][-1]
        if structure is not None:
            inputs = (structure.x, structure.v, structure.acceleration(force))
            report = sim.advance(h, u, inputs)
            force = report.impulse / h
            structure.step(h, force)
        elif kind == "modal":
            loads = [loads for since, loads in MODE_LOADS if since <= t + 1e-12][-1]
            report = sim.advance(h, u, loads=loads)
        else:
            report = sim.advance(h, u)
        reports.append(report)
    return sim, reports


def fingerprint(name: str, kind: str, changes: dict, t_end: float, h: float, flow) -> dict:
    """Per quantity, the digest of every number the case reports, and their count."""
    scene = Scene(**changes)
    out: dict[str, list[str]] = {}
    if kind == "run":
        result = run(scene, t_end, dt=h)
        for key in ("t", "x", "v", "z", "w", "impulse", "gap", "penetration", "sticking"):
            out[key] = [_number(value) for value in getattr(result, key)]
        impacts = result.impacts
        for key in _IMPACT:
            out[f"impact_{key}"] = [_number(value) for value in impacts[key]]
        return {key: _digest(values) for key, values in out.items()}
    sim, reports = stepped(scene, kind, t_end, h, flow)
    reported = _REPORTED + (_MODAL if kind == "modal" else ())
    out = {key: [_number(getattr(report, key)) for report in reports] for key in reported}
    for key in _IMPACT:
        out[f"impact_{key}"] = [_number(getattr(i, key)) for i in sim.impacts]
    return {key: _digest(values) for key, values in out.items()}


def compute(names: list[str] | None = None) -> dict[str, dict[str, str]]:
    return {case[0]: fingerprint(*case) for case in CASES if names is None or case[0] in names}


def event_quantities(digests: dict[str, str]) -> dict[str, str]:
    """The digests of a run's events: its impacts (times, velocities, impulses, counts) and its
    sticking flags (what holds where the C library runs its SSE2 variants: test_machine_matrix)."""
    return {key: value for key, value in digests.items()
            if key.startswith("impact") or key == "sticking"}


def libm_has_fma_variants() -> bool:
    """Whether this CPU has FMA and AVX2, with which glibc runs the variants of exp, sin, cos...
    the stored digests were made with (elsewhere: its SSE2 ones, whose last bits differ for about
    1 argument in 1,000)."""
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return True
    flags = next((line for line in text.splitlines() if line.startswith("flags")), "").split()
    return not flags or {"fma", "avx2"} <= set(flags)


def stored() -> dict[str, dict[str, str]]:
    return json.loads(STORED.read_text())


if __name__ == "__main__":
    target = Path(sys.argv[1]) if len(sys.argv) > 1 else STORED
    target.write_text(json.dumps(compute(), indent=1, sort_keys=True) + "\n")
    print(f"wrote {target}")
