"""Random engineering-plausible scenes over every feature, and the check that each runs soundly.

:func:`draw` makes one case from a seed: the ranges a designer meets (structure mass 1e3 to
1e6 kg, natural frequency 0.3 to 10 Hz, damping ratio 0.5 to 10 %; ice mass 1e2 to 1e6 kg, area
0.5 to 100 m^2, Cd 0.5 to 2; flow 0.05 to 2 m/s; e from 0 to 1, both drag laws; Morison terms on
the structure in half the built-in ones), over every kind of structure and method:

- ``sdof``: the built-in structure, methods 1 to 3;
- ``modal``: 1 to 3 modes at the contact point (structure.model = 3), methods 1 to 3, with
  generalized loads on the modes;
- ``external``: the ice against a scripted structure (structure.model = 2, an exact SDOF stepped
  by a Gauss-Seidel or Jacobi master, tests/coupling_master.py);

and a share of the built-in and modal cases also through the FMU (FMPy, FMI 2.0 and FMI 3.0 with
early return). :func:`check` runs a case and returns what is wrong with it (None: sound):

- refused up front: only by a ParameterError that names the parameter and its limit;
- finite outputs; the gap never negative beyond the method's tolerance, no tensile contact
  impulse beyond rounding;
- the energy of the bodies never grows once the flow stops (the last 2 s of each run, at u = 0;
  methods 1 and 2 to rounding, method 3 within its integration's error);
- method 1's compiled march equal to the Python march to the bit (every step, its modal state
  and impact), for the SDOF and the modal structure;
- the FMU's outputs equal the core's to the bit (FMPy on the same grid; FMI 3.0 with early return
  on its grid rows);
- no single communication step over STEP_CPU s of CPU.

Each case is reproducible from its seed: ``python tests/plausible_scenes.py SEED`` prints it and
what :func:`check` finds.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field

import numpy as np

from coupling_master import ExactSdof, gauss_seidel, jacobi
from iceimpact import ParameterError, Scene, Simulator, SolverError

#: CPU time one communication step may take, s
STEP_CPU = 20.0
#: the communication step of every case, s, and the horizons (s) of each kind of case (the flow
#: stops for the last ZERO_FLOW of each)
H = 1e-2
HORIZON = {1: 30.0, 2: 10.0, 3: 5.0}
ZERO_FLOW = 2.0
#: the gap's tolerance (m) and the contact impulse's (relative to the momentum scale) by method
GAP_TOLERANCE = {1: 1e-12, 2: math.inf, 3: 1e-9}
IMPULSE_TOLERANCE = {1: 1e-9, 2: 1e-9, 3: 1e-5}
#: the energy's growth allowed at u = 0, relative to its scale, by method
ENERGY_TOLERANCE = {1: 1e-9, 2: 1e-9, 3: 1e-5}


@dataclass
class Case:
    """One case: the scene's keyword arguments, its kind, and whether it also runs as an FMU."""

    seed: int
    kind: str
    scene: dict
    horizon: float
    scheme: str = ""           # external: "gauss-seidel" or "jacobi"
    fmu: bool = False
    loads: tuple = ()          # modal: the modes' loads (N)
    notes: list = field(default_factory=list)


def _log_uniform(rng: np.random.Generator, low: float, high: float) -> float:
    return float(math.exp(rng.uniform(math.log(low), math.log(high))))


def draw(seed: int) -> Case:
    """The case of ``seed`` (see the module docstring)."""
    rng = np.random.default_rng(seed)
    kind = str(rng.choice(["sdof", "modal", "external"], p=[0.55, 0.3, 0.15]))
    m = _log_uniform(rng, 1e3, 1e6)
    f = _log_uniform(rng, 0.3, 10.0)
    zeta = rng.uniform(0.005, 0.1)
    k = m * (2.0 * math.pi * f) ** 2
    c = 2.0 * zeta * math.sqrt(k * m)
    u = _log_uniform(rng, 0.05, 2.0)
    e = float(rng.choice([0.0, 1.0, rng.uniform(0.0, 1.0)], p=[0.15, 0.15, 0.7]))
    scene = {"ice_M": _log_uniform(rng, 1e2, 1e6), "ice_A": _log_uniform(rng, 0.5, 100.0),
             "ice_Cd": rng.uniform(0.5, 2.0), "flow_u": u, "impact_e": e,
             "drag_model": int(rng.integers(1, 3)), "ice_v0": rng.uniform(0.0, 2.0 * u),
             "ice_z0": -rng.uniform(0.0, 0.5)}
    method = 1 if kind == "external" else int(rng.choice([1, 2, 3], p=[0.6, 0.2, 0.2]))
    scene["solver_method"] = method
    if method == 2:
        scene["solver_dt"] = float(rng.choice([1e-4, 1e-3]))
    case = Case(seed, kind, scene, HORIZON[method])
    if kind == "modal":
        n = int(rng.integers(1, 4))
        scene.update(structure_model=3, structure_modes=n)
        loads = []
        for j in range(1, n + 1):
            mj = m if j == 1 else _log_uniform(rng, 1e3, 1e6)
            fj = f if j == 1 else _log_uniform(rng, 0.3, 10.0)
            scene.update({f"structure_mode{j}_f": fj,
                          f"structure_mode{j}_zeta": zeta if j == 1 else rng.uniform(0.005, 0.1),
                          f"structure_mode{j}_m": mj,
                          f"structure_mode{j}_phi": 1.0 if j == 1 else rng.uniform(-1.0, 1.0)})
            loads.append(rng.uniform(-0.05, 0.05) * mj * (2.0 * math.pi * fj) ** 2 * 1e-3)
        case.loads = tuple(loads)
    else:
        scene.update(structure_m=m, structure_k=k, structure_c=c)
        if kind == "external":
            scene.update(structure_model=2, coupling_scheme=int(rng.integers(1, 3)))
            case.scheme = "gauss-seidel" if scene["coupling_scheme"] == 1 else "jacobi"
            case.horizon = 10.0
        elif rng.uniform() < 0.5:  # Morison terms on the structure
            scene.update(structure_Ca=rng.uniform(0.5, 1.0),
                         structure_V=m / 1025.0 * rng.uniform(0.01, 0.5),
                         structure_Cd=rng.uniform(0.5, 2.0),
                         structure_A=_log_uniform(rng, 0.5, 10.0))
    case.fmu = kind != "external" and rng.uniform() < 0.05
    return case


def _energy(scene: Scene, sim: Simulator, loads: tuple) -> float:
    """The bodies' mechanical energy (J): the structure's (its modes', with the potential
    -L_k q_k of each held load, for the modal one) and the ice's kinetic energy."""
    s = sim.solver.state
    ice = 0.5 * scene.ice_M * s.w * s.w
    if scene.modal:
        q, p = sim.solver.modal_state()
        total = ice
        for (f, _, m, _, _, _), load, qk, pk in zip(scene.mode_table, loads, q, p, strict=True):
            total += 0.5 * m * pk * pk + 0.5 * m * (2.0 * math.pi * f) ** 2 * qk * qk - load * qk
        return total
    return ice + 0.5 * scene.structure_mass * s.v * s.v + 0.5 * scene.structure_k * s.x * s.x


def _bits(report) -> tuple:
    """A report's state and impulse, and its modal state (0 without the modal structure)."""
    return tuple(float(getattr(report, name)).hex() for name in (
        "x", "v", "z", "w", "impulse", *(f"mode{k}_{q}" for k in range(1, 6) for q in "qv")))


def check(case: Case, fmus: tuple | None = None) -> str | None:
    """What is wrong with ``case`` (None: sound, or refused up front naming the limit);
    ``fmus`` (IceImpact.fmu, IceImpact3.fmu) for the cases that run as FMUs too."""
    try:
        scene = Scene(**case.scene)
    except ParameterError as exc:
        text = str(exc)
        if " is not allowed: " not in text:
            return f"a refusal that names no limit: {text}"
        case.notes.append(f"refused: {text}")
        return None
    if case.kind == "external":
        return _check_external(case, scene)
    with np.errstate(all="raise", under="ignore"):
        return _check_stepped(case, scene, fmus)


def _check_stepped(case: Case, scene: Scene, fmus: tuple | None) -> str | None:
    method = scene.solver_method
    n = round(case.horizon / H)
    zero_from = n - round(ZERO_FLOW / H)
    runs = [Simulator(scene)]
    if method == 1 and runs[0].solver.bounces is not None:
        runs.append(Simulator(scene))
        runs[1].solver.bounces = None  # the Python march alone
    loads = case.loads or None
    e_last = e_scale = _energy(scene, runs[0], case.loads)
    trace = []
    for i in range(n):
        u = scene.flow_u if i < zero_from else 0.0
        reports = []
        for sim in runs:
            start = time.process_time()
            try:
                reports.append(sim.advance((i + 1) * H - sim.t, u, loads=loads))
            except (ParameterError, SolverError) as exc:
                return f"refused at step {i} (t = {sim.t} s): {exc}"
            if time.process_time() - start > STEP_CPU:
                return f"step {i} took over {STEP_CPU} s of CPU"
        r = reports[0]
        if len(reports) == 2 and _bits(r) != _bits(reports[1]):
            return f"the compiled march differs from the Python one at t = {r.t} s"
        values = (r.x, r.v, r.z, r.w, r.gap, r.penetration, r.impulse, r.force)
        if not all(map(math.isfinite, values)):
            return f"non-finite output at t = {r.t} s: {values}"
        s = runs[0].solver.state
        if s.x - s.z < -GAP_TOLERANCE[method] * max(1.0, abs(s.x)):
            return f"gap {s.x - s.z} m at t = {r.t} s"
        mass = scene.structure_mass + scene.ice_M
        momentum = mass * (abs(s.v) + abs(s.w) + abs(scene.flow_u)) + 1e-300
        if r.impulse < -IMPULSE_TOLERANCE[method] * momentum:
            return f"tensile contact impulse {r.impulse} N.s at t = {r.t} s"
        e_now = _energy(scene, runs[0], case.loads)
        e_scale = max(e_scale, abs(e_now))
        if i > zero_from and e_now > e_last + ENERGY_TOLERANCE[method] * e_scale + 1e-300:
            return f"energy created at u = 0: {e_last} -> {e_now} J at t = {r.t} s"
        e_last = e_now
        trace.append(r)
    if case.fmu and fmus is not None:
        return _check_fmu(case, scene, trace, fmus)
    return None


def _fmi_values(case: Case, scene: Scene) -> dict:
    """The scene's values that differ from the defaults, by FMI name."""
    default = Scene().to_fmi()
    return {name: value for name, value in scene.to_fmi().items() if value != default[name]}


def _check_fmu(case: Case, scene: Scene, trace: list, fmus: tuple) -> str | None:
    """The FMU's structure.x equals the stepped core's to the bit (the flow held; the loads as
    start values of the inputs); FMI 3.0 with early return equal on its grid rows."""
    from fmpy import simulate_fmu

    values = _fmi_values(case, scene)
    for k, load in enumerate(case.loads, start=1):
        values[f"structure.mode{k}.load"] = load
    t_stop = ZERO_FLOW  # (the flow held at its start value: the first steps of the trace)
    steps = round(t_stop / H)
    expected = np.array([r.x for r in trace[:steps]])
    for path, early in ((fmus[0], False), (fmus[1], True)):
        result = simulate_fmu(str(path), start_values=values, stop_time=t_stop,
                              output_interval=H, early_return_allowed=early,
                              output=["structure.x"])
        times = result["time"]
        grid = np.arange(1, steps + 1) * H
        rows = np.isin(times, grid) if early else slice(1, steps + 1)
        got = result["structure.x"][rows]
        if len(got) != steps or not np.array_equal(got, expected):
            return f"{path.name} (early return {early}) differs from the core"
    return None


def _check_external(case: Case, scene: Scene) -> str | None:
    """The ice against an exact SDOF by the case's master: finite, no tensile impulse."""
    sim = Simulator(scene)
    structure = ExactSdof(scene.structure_m, scene.structure_c, scene.structure_k)

    class Ice:
        def step(self, t, h, x_in, v_in, a_in):
            start = time.process_time()
            report = sim.advance(h, structure=(x_in, v_in, a_in))
            if time.process_time() - start > STEP_CPU:
                raise RuntimeError(f"a step took over {STEP_CPU} s of CPU")
            return report.impulse

    master = gauss_seidel if case.scheme == "gauss-seidel" else jacobi
    try:
        run = master(Ice(), structure, case.horizon, H)
    except (ParameterError, SolverError) as exc:
        return f"refused at t = {sim.t} s: {exc}"
    if not (np.isfinite(run.x).all() and np.isfinite(run.impulse).all()):
        return "non-finite output"
    momentum = (scene.structure_m + scene.ice_M) * (np.max(np.abs(run.v)) + scene.flow_u
                                                    + abs(scene.ice_v0))
    if np.min(run.impulse) < -IMPULSE_TOLERANCE[1] * momentum:
        return f"tensile contact impulse {np.min(run.impulse)} N.s"
    return None


if __name__ == "__main__":
    for text in sys.argv[1:]:
        case = draw(int(text))
        print(case)
        print(check(case))
