"""Ice on a two-mode structure: the modes inside IceImpact (``structure.model = 3``) against the
co-simulation with ModalStructure.fmu, and a smooth load from another FMU driving the modes.

    python build_fmu.py
    python benchmarks/modal_coupling.py [--fmus dist] [--out benchmarks/results]

The scene is ``benchmarks/coupling.py``'s impacting one (quadratic drag, u = 0.3 m/s, M = 1200
kg, e = 0.7) on two modes seen at the contact point: mode 1 is the built-in structure (1600 kg,
200 N.s/m, 1e6 N/m, phi = 1), mode 2 is 11 Hz, 2 % damping, modal mass 1600 kg, phi = 0.6.

Rows:

- **modes inside**: IceImpact's core with ``structure.model = 3`` (method 1), sampled at the
  communication points;
- **FMPy GS / FMPy Jacobi**: IceImpact.fmu (``structure.model = 2``) and ModalStructure.fmu (two
  modes) in the scripted FMPy loop of ``examples/system/system.py``, orders 1 and 2 (order 2
  passes the structure's acceleration); IceImpact's ``structure.m`` is the effective mass at the
  contact point, ``1 / sum phi_k^2 / m_k`` = 1176 kg;
- **load-driven, Jacobi**: IceImpact.fmu (``structure.model = 3``) and a sine-load FMU built here
  (PythonFMU, output ``force = A sin(2 pi f t)``) in a Jacobi loop: ``force -> mode1.load`` and
  ``0.6 force -> mode2.load`` (the force at the contact point projected on the modes, phi_k F);
  order "held" holds each load over a step (``structure.load_order = 0``), "linear" continues
  it at its rate between the last two communication points (``structure.load_order = 1``).

Reference: tests/modal_reference.py, the monolithic system integrated by scipy's DOP853 (rtol
1e-12) with the gap and the riding contact force as events, impact by impact; it shares no code
with IceImpact's solvers. A Zeno sequence is closed by a plastic impact once the approach speed
falls under 1e-7 m/s; the ice then rides while the contact force is compressive. The
load-driven reference takes the load as a continuous function of time.

Per row: **x error** ``max |x - x_ref| / max |x_ref|`` over the communication points of the first
2.6 s, **impacts** (run / reference: all of them, save for the modes inside, whose count and
impact-time error, the largest ``|t - t_ref|`` over the reference's impacts each matched to the
run's nearest one, take the impacts with an approach speed over 1e-4 m/s).

Writes ``modal_coupling.json`` and ``modal_coupling.md`` to ``--out``.
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np
from tree import ROOT, load

from iceimpact import Scene
from iceimpact.simulator import Simulator

system = load("examples/system/system.py")
modal_reference = load("tests/modal_reference.py")

T_END = 2.6
STEPS = (1e-2, 1e-3, 1e-4)
#: the scene: quadratic drag, u = 0.3 m/s, M = 1200 kg, e = 0.7 (coupling.py's impacting scene)
ICE = {"drag_model": 2, "flow_u": 0.3, "ice_M": 1200.0, "impact_e": 0.7}
#: the modes (f Hz, zeta, modal mass kg, phi at the contact point)
MODE1 = (math.sqrt(1e6 / 1600.0) / (2.0 * math.pi), 200.0 / (2.0 * math.sqrt(1e6 * 1600.0)),
         1600.0, 1.0)
MODE2 = (11.0, 0.02, 1600.0, 0.6)
MODES = (MODE1, MODE2)
#: the smooth loads at the contact point, F = A sin(2 pi f t): (A N, f Hz)
LOADS = ((2.0e4, 0.1), (2.0e4, 0.3), (2.0e4, 0.5))
#: approach speed over which an impact is counted and matched, m/s
COUNTED = 1e-4
#: the reference closes a Zeno sequence with a plastic impact once the approach speed is below
#: this (m/s): the bounces after it move the contact point by less than 1e-12 m
CHATTER_SPEED = 1e-7


# the independent reference -----------------------------------------------------------------------
class Reference:
    """The scene integrated impact by impact by the tests' independent reference
    (tests/modal_reference.py: DOP853 at rtol 1e-12, no code shared with the solvers), the loads
    ``load`` (t -> one per mode, N) given as a continuous function of time, or none."""

    def __init__(self, load=None):
        self.load = load
        self.impacts: list[tuple[float, float]] = []  # (t, approach speed)

    def run(self, t_end: float, times: np.ndarray) -> np.ndarray:
        """x at ``times`` (from 0, in [0, t_end]); the impacts go to ``self.impacts``."""
        scene = modal_scene()
        result = modal_reference.simulate(scene, t_end, sample_times=times[1:],
                                          loads=self.load, chatter_speed=CHATTER_SPEED)
        self.impacts = [(i.t, i.w_minus - i.v_minus) for i in result.impacts]
        return np.concatenate(([scene.modal_start[0]], result.x))


def reference(load=None) -> Reference:
    return Reference(load)


# the runs ----------------------------------------------------------------------------------------
def modal_scene(**extra) -> Scene:
    values = {"structure_model": 3, "structure_modes": 2}
    for k, (f, zeta, m, phi) in enumerate(MODES, start=1):
        values.update({f"structure_mode{k}_f": f, f"structure_mode{k}_zeta": zeta,
                       f"structure_mode{k}_m": m, f"structure_mode{k}_phi": phi})
    return Scene(**ICE, **values, **extra)


def inside_run(h: float) -> tuple[np.ndarray, list]:
    """The modes inside IceImpact: x at the communication points, and the impacts."""
    sim = Simulator(modal_scene())
    n = round(T_END / h)
    x = [sim.report.x] + [sim.advance_to((k + 1) * h).x for k in range(n)]
    return np.array(x), list(sim.impacts)


def modal_values() -> dict:
    """ModalStructure.fmu's parameters for the two modes."""
    values = {"modes": 2}
    for k, (f, zeta, m, phi) in enumerate(MODES, start=1):
        values.update({f"mode{k}.f": f, f"mode{k}.zeta": zeta, f"mode{k}.m": m,
                       f"mode{k}.phi": phi})
    return values


def effective_mass() -> float:
    """The structure's mass seen at the contact point, ``1 / sum phi_k^2 / m_k``: the mass the
    ice's impact law takes for an external structure (structure.m)."""
    return 1.0 / sum(phi ** 2 / m for _, _, m, phi in MODES)


def cosim_run(fmus: Path, h: float, scheme: str, order: int) -> dict:
    ice = {"structure.model": 2, "drag.model": ICE["drag_model"], "ice.M": ICE["ice_M"],
           "impact.e": ICE["impact_e"], "structure.m": effective_mass()}
    result = system.fmpy_master(fmus, T_END, h, scheme, ice=ice, structure=modal_values(),
                                flow_u=ICE["flow_u"], second_order=order == 2)
    return {"x": result["x"], "count": int(result["count"])}


SINE_SLAVE = '''
import math
from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real


class SineLoad(Fmi2Slave):
    """A force A sin(2 pi f t), the value at the end of each step."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.A, self.f, self.force = 1.0, 0.1, 0.0
        self.register_variable(Real("A", causality=Fmi2Causality.parameter,
                                    variability=Fmi2Variability.fixed))
        self.register_variable(Real("f", causality=Fmi2Causality.parameter,
                                    variability=Fmi2Variability.fixed))
        self.register_variable(Real("force", causality=Fmi2Causality.output))

    def do_step(self, current_time, step_size):
        self.force = self.A * math.sin(2.0 * math.pi * self.f * (current_time + step_size))
        return True
'''


def build_sine_fmu(dest: Path) -> Path:
    """SineLoad.fmu (PythonFMU), built into ``dest``."""
    from pythonfmu import FmuBuilder

    script = dest / "SineLoad.py"
    script.write_text(SINE_SLAVE)
    return Path(FmuBuilder.build_FMU(script, dest=dest))


class Slave(system.Slave):
    """FMPy's FMU2Slave with IceImpact's structure.modes as an Integer."""

    def set(self, name: str, value) -> None:
        if name in ("structure.modes", "structure.load_order"):
            self.fmu.setInteger([self.vr[name]], [int(value)])
        else:
            super().set(name, value)


def load_driven_run(fmus: Path, sine: Path, h: float, amplitude: float,
                    frequency: float, order: int = 0) -> dict:
    """IceImpact.fmu's modes driven by SineLoad.fmu, Jacobi: both step from the values at t;
    IceImpact holds each load over the step (``order`` 0) or continues it at its last rate
    (1: structure.load_order)."""
    ice = {"structure.model": 3, "structure.modes": 2, "drag.model": ICE["drag_model"],
           "ice.M": ICE["ice_M"], "impact.e": ICE["impact_e"], "flow.u": ICE["flow_u"],
           "structure.load_order": order}
    for k, (f, zeta, m, phi) in enumerate(MODES, start=1):
        ice.update({f"structure.mode{k}.f": f, f"structure.mode{k}.zeta": zeta,
                    f"structure.mode{k}.m": m, f"structure.mode{k}.phi": phi})
    ice_fmu = Slave(fmus / "IceImpact.fmu", "ice", ice)
    source = system.Slave(sine, "load", {"A": amplitude, "f": frequency})
    n = round(T_END / h)
    x = [ice_fmu.get("structure.x")]
    try:
        for k in range(n):
            force = source.get("force")  # the value at t, held over [t, t + h]
            for j, mode in enumerate(MODES, start=1):
                ice_fmu.set(f"structure.mode{j}.load", mode[3] * force)
            source.step(k * h, h)
            ice_fmu.step(k * h, h)
            x.append(ice_fmu.get("structure.x"))
        count = ice_fmu.get_integer("contact.count")
    finally:
        ice_fmu.close()
        source.close()
    return {"x": np.array(x), "count": int(count)}


def sine_load(amplitude: float, frequency: float):
    """The generalized loads ``L_k(t) = phi_k A sin(2 pi f t)`` as a continuous function."""
    phi = np.array([mode[3] for mode in MODES])
    return lambda t: phi * amplitude * math.sin(2.0 * math.pi * frequency * t)


# measures ----------------------------------------------------------------------------------------
def x_error(x: np.ndarray, x_ref: np.ndarray) -> float:
    n = min(len(x), len(x_ref))
    return float(np.max(np.abs(x[:n] - x_ref[:n])) / np.max(np.abs(x_ref[:n])))


def impact_time_error(impacts: list, ref: Reference) -> tuple[float, int, int]:
    """Largest |t - t_ref| over the reference's counted impacts, each matched to the run's
    nearest counted impact; and the counts (run, reference)."""
    run_t = np.array([i.t for i in impacts if i.w_minus - i.v_minus > COUNTED])
    ref_t = np.array([t for t, approach in ref.impacts if approach > COUNTED])
    if not len(run_t) or not len(ref_t):
        return math.nan, len(run_t), len(ref_t)
    worst = max(float(np.min(np.abs(run_t - t))) for t in ref_t)
    return worst, len(run_t), len(ref_t)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fmus", type=Path, default=ROOT / "dist",
                        help="folder with IceImpact.fmu and ModalStructure.fmu")
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    args = parser.parse_args(argv)

    # built before any FMU runs: a loaded PythonFMU FMU puts its own bundled pythonfmu (removed
    # with the FMU's folder when it is freed) first on sys.path
    tmp = Path(tempfile.mkdtemp())
    sine = build_sine_fmu(tmp)
    finest = np.arange(round(T_END / min(STEPS)) + 1) * min(STEPS)
    ref = reference()
    x_fine = ref.run(T_END, finest)

    def on_grid(x_f: np.ndarray, h: float) -> np.ndarray:
        return x_f[::round(h / min(STEPS))]

    rows = []
    lines = ["| system | master | order | h (s) | x error | impacts (run / ref) | "
             "impact-time error (s) | wall (s) |", "|---|---|---|---|---|---|---|---|"]

    def add(system_name: str, master: str, order: str, h: float, x: np.ndarray, counts,
            dt: float, wall: float, x_ref: np.ndarray) -> None:
        row = {"system": system_name, "master": master, "order": order, "h": h,
               "x_error": x_error(x, x_ref), "impacts": counts[0], "impacts_ref": counts[1],
               "impact_time_error": dt, "wall": wall}
        rows.append(row)
        dt_text = "" if math.isnan(dt) else f"{dt:.1e}"
        err = row["x_error"]
        err_text = f"{err:.2%}" if err >= 1e-4 else f"{err:.1e}"
        line = (f"| {system_name} | {master} | {order} | {h:g} | {err_text} | "
                f"{counts[0]} / {counts[1]} | {dt_text} | {wall:.2f} |")
        lines.append(line)
        print(line, flush=True)

    n_ref = len(ref.impacts)
    two = "ice on two modes"
    for h in STEPS:
        start = time.perf_counter()
        x, impacts = inside_run(h)
        wall = time.perf_counter() - start
        dt, n_run, n_r = impact_time_error(impacts, ref)
        add(two, "modes inside (structure.model = 3)", "", h, x, (n_run, n_r), dt, wall,
            on_grid(x_fine, h))
    for scheme, label in (("gauss-seidel", "FMPy GS"), ("jacobi", "FMPy Jacobi")):
        for order in (1, 2):
            for h in STEPS:
                start = time.perf_counter()
                result = cosim_run(args.fmus, h, scheme, order)
                add(two, f"{label}, ModalStructure.fmu", str(order), h, result["x"],
                    (result["count"], n_ref), math.nan, time.perf_counter() - start,
                    on_grid(x_fine, h))
    try:
        for amplitude, frequency in LOADS:
            loaded = reference(sine_load(amplitude, frequency))
            x_fine_loaded = loaded.run(T_END, finest)
            for order in (0, 1):
                for h in STEPS:
                    start = time.perf_counter()
                    result = load_driven_run(args.fmus, sine, h, amplitude, frequency, order)
                    add(f"two modes + SineLoad.fmu (A = {amplitude:g} N, f = {frequency:g} Hz)",
                        "Jacobi, modes inside", "held" if order == 0 else "linear", h,
                        result["x"], (result["count"], len(loaded.impacts)), math.nan,
                        time.perf_counter() - start, on_grid(x_fine_loaded, h))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "modal_coupling.json").write_text(json.dumps(
        {"t_end": T_END, "modes": MODES, "loads": LOADS, "rows": rows},
        indent=1) + "\n")
    (args.out / "modal_coupling.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
