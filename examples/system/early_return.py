"""Early return in the coupled system: IceImpact3.fmu (structure.model = 2, Gauss-Seidel) and
ModalStructure3.fmu in scripted FMI 3.0 masters over FMPy's low-level API, with and without the
floe's early return at its contact events.

The system is that of ``system.py`` (the same parameters and connections)::

    floe.coupling.force -> structure.force
    structure.x         -> floe.structure.x_in
    structure.v         -> floe.structure.v_in
    structure.a         -> floe.structure.a_in

Every master is a Gauss-Seidel loop, floe first (``coupling.scheme = 1``), on the communication
grid ``k h``; the structure's state is recorded at each grid point. The masters
(:data:`MASTERS`):

- ``plain``: the FMI 2.0 loop of ``system.fmpy_master`` on the FMI 3.0 FMUs, the floe
  instantiated without ``earlyReturnAllowed``: an impact inside a step reaches the structure as
  the step's mean force, held over the step.
- ``early``: the floe is instantiated with ``earlyReturnAllowed`` and ends a step at its first
  contact event (an impact, or the ice separating from the structure it rode on) at ``t_e``. The
  structure is then stepped to ``t_e``, the values are exchanged and the floe goes on from
  ``t_e`` to the same grid point. A step that ended at an impact (its ``contact.t_last`` is
  ``t_e``) was a flight ending in that impact, so its impulse ``J`` (``contact.impulse``) must
  reach the structure *at* the impact: the structure steps ``[t, t_e - kick]`` with no force and
  ``[t_e - kick, t_e]`` with ``J / kick`` (:data:`KICK`). Any other step (riding, ending at a
  separation or at the grid point, or one whose impact was at its very start, the ice meeting
  the structure again where it left it) holds the floe's ``coupling.force`` over the step as
  usual.
- ``early+approach``: as ``early``, and an early return at ``t_e`` more than ``2 approach``
  after the step start ``t_s`` is taken back: the floe returns to its state at ``t_s``
  (fmi3GetFMUState / fmi3SetFMUState) and steps to ``t_e - approach`` with the same inputs (the
  same computation, so no event before that point), the structure follows, the values are
  exchanged, and the floe goes on to the event from there. The last stretch before each event
  is at most ``approach`` long (:data:`APPROACH`), so the floe's polynomial extrapolation of the
  structure over the flight before an impact is short. The structure needs no rollback: in a
  floe-first loop it has not moved past ``t_s`` when the floe returns. ``APPROACH = 0.1 ms``:
  on the impacting scene, against approaches of 1 ms, the x error is 2.2 % instead of 2.7 % at
  10 ms steps and a quarter at 3 ms, the impact times a fourteenth at both, for the same number
  of doSteps; shorter gains little (``benchmarks/coupling_early_return.py``, its approach
  table).

The ``a_in`` protocol is kept: IceImpact measures the structure's own force as ``m a_in`` minus
the force it returned for the last step (``coupling.force``), so the structure's ``a`` is read
with ``force`` equal to that value (ModalStructure3's ``a`` is its acceleration under the current
``force``, a direct feedthrough). After a kick the structure's ``force`` is set back from
``J / kick`` to the connection's value, ``coupling.force``, before ``a`` is read; read under
``J / kick`` it would hand IceImpact a structure force off by about ``J / kick`` (measured: the
run diverges, x errors of thousands of per cent).

Why the kick and why ``KICK = 1e-7 s``: the impulse spread over the whole early step (as the
force held) would start moving the structure before the impact, which the floe does not see;
the structure it reports next would then be ahead of the floe's, and the next flight starts
from the wrong state (and spurious impacts follow). A force ``J / kick`` over the last ``kick``
seconds is the impact's impulse to first order in ``kick``: the structure's displacement at
``t_e`` is off by ``J kick / (2 m)`` (about 1e-8 m for J = 300 N.s on 1600 kg), its velocity by
``O(omega^2 kick^2)``, both far below the coupling error at any h here; ModalStructure3 steps
such a short interval exactly (its coefficients are summed as series, no cancellation). Shorter
kicks change nothing measurable; from 10 us on the results move (``benchmarks/
coupling_early_return.py``, its kick table).

Every run returns a dict: ``time``, ``x`` (the structure's, at the grid points), ``impulse``
(the contact impulses delivered to the structure, N.s), ``count`` (contact.count at the end),
``impacts`` (the impact times as the floe reported them: its ``contact.t_last`` after each step
whose ``contact.count`` grew; the earlier impacts of a step with several, which the plain master
cannot see, are NaN), ``at_start`` (per impact: it was at the very start of its step; after an
early return at a separation the floe can meet the structure it has just left, at a relative
velocity of rounding size, and counts it as an impact), ``steps`` (the number of doStep calls of
each FMU, rolled-back ones included), and with ``trace=True`` ``returns`` (one record per early
return, see :func:`early_return_master`) and ``exchanges`` (the floe's and the structure's FMI
time variable at each exchange).

Run ``python examples/system/early_return.py --fmus dist`` after ``python build_fmu.py``: it runs
the three masters at a few communication steps on the impacting scene and prints the error of
the structure's displacement against IceImpact's own monolithic run (the built-in structure,
``structure.model = 1``) and the error of the impact times, measured as
``benchmarks/coupling_early_return.py`` measures them (which runs both scenes at every step):
against the impacts a coupled run can meet (:func:`reachable_impacts`, the monolithic run's Zeno
sequences closed at the chatter time), matched in order, the impacts at a step start left out.
The rows at 10, 3 and 1 ms are those of docs/explanation/coupling.md's early-return table.
"""

from __future__ import annotations

import argparse
import math
import shutil
from pathlib import Path

import numpy as np

from system import (
    FLOW_U,
    ICE,
    ICE_COMPONENT,
    INTEGERS,
    SCHEMES,
    STRUCTURE,
    STRUCTURE_COMPONENT,
    connections,
)

#: The masters, in the order of the module docstring.
MASTERS = ("plain", "early", "early+approach")
#: Length of the structure's step that takes an impact's impulse as the force J / KICK, s.
KICK = 1e-7
#: Longest last approach to an event of the ``early+approach`` master, s.
APPROACH = 1e-4
#: The name of FMI 3.0's independent variable in the project's FMUs.
TIME = "time"


class Slave3:
    """One FMU3Slave stepped by hand (FMPy's default logger), values by name."""

    def __init__(self, fmu: Path, name: str, values: dict, early_return: bool = False):
        from fmpy import extract, read_model_description
        from fmpy.fmi3 import FMU3Slave

        md = read_model_description(str(fmu))
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.dir = extract(str(fmu))
        self.fmu = FMU3Slave(guid=md.guid, unzipDirectory=self.dir,
                             modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        self.fmu.instantiate(earlyReturnAllowed=early_return)
        self.fmu.enterInitializationMode(startTime=0.0)
        for key, value in values.items():
            self.set(key, value)
        self.fmu.exitInitializationMode()
        self.steps = 0
        self.state = None

    def set(self, name: str, value) -> None:
        if name in INTEGERS:
            self.fmu.setInt32([self.vr[name]], [int(value)])
        else:
            self.fmu.setFloat64([self.vr[name]], [float(value)])

    def refs(self, *names: str) -> list[int]:
        return [self.vr[name] for name in names]

    def get(self, name: str) -> float:
        return self.fmu.getFloat64([self.vr[name]])[0]

    def step(self, t: float, dt: float, rollback: bool = False) -> tuple[bool, float]:
        """doStep from ``t`` over ``dt``: (early return, the time reached). ``rollback``: the
        master may set a state from before ``t`` (noSetFMUStatePriorToCurrentPoint = false)."""
        self.steps += 1
        _, terminate, early, reached = self.fmu.doStep(
            t, dt, noSetFMUStatePriorToCurrentPoint=not rollback)
        if terminate:
            raise RuntimeError(f"{self.fmu.instanceName} asks to terminate at t = {reached!r} s")
        return early, (reached if early else t + dt)

    def save(self) -> None:
        """Keep the FMU state (one at a time: the previous one is freed)."""
        if self.state is not None:
            self.fmu.freeFMUState(self.state)
        self.state = self.fmu.getFMUState()

    def restore(self) -> None:
        self.fmu.setFMUState(self.state)

    def close(self) -> None:
        if self.state is not None:
            self.fmu.freeFMUState(self.state)
            self.state = None
        self.fmu.terminate()
        self.fmu.freeInstance()
        shutil.rmtree(self.dir, ignore_errors=True)


def early_return_master(fmus: Path, t_end: float, h: float, master: str = "early",
                        ice: dict = ICE, structure: dict = STRUCTURE, flow_u: float = FLOW_U,
                        kick: float = KICK, approach: float = APPROACH,
                        second_order: bool = True, trace: bool = False) -> dict:
    """The coupled run of ``master`` (one of :data:`MASTERS`) from 0 to ``t_end`` on the grid
    ``k h`` (see the module docstring for the masters and the result).

    With ``trace`` the result also has ``returns``, one record per early return kept (not
    rolled back): ``(t_start, t_reached, count_before, count_after, t_last, riding_before,
    riding_after, gap)`` (``contact.count``, ``contact.t_last`` and ``contact.active`` before
    and after the step, ``contact.gap`` after it), and ``exchanges``: the floe's and the
    structure's ``time`` at each exchange, as an (n, 2) array."""
    if master not in MASTERS:
        raise ValueError(f"master {master!r}: one of {MASTERS}")
    early_return = master != "plain"
    approaching = master == "early+approach"
    floe = Slave3(fmus / "IceImpact3.fmu", ICE_COMPONENT,
                  {**ice, "coupling.scheme": SCHEMES["gauss-seidel"], "flow.u": flow_u},
                  early_return=early_return)
    st = Slave3(fmus / "ModalStructure3.fmu", STRUCTURE_COMPONENT, structure)
    links = connections(second_order)[1:]
    sources = st.refs(*(source for _, source, _, _ in links))
    sinks = floe.refs(*(sink for _, _, _, sink in links))
    outputs = floe.refs("contact.impulse", "coupling.force", "contact.t_last", "contact.gap")
    count_ref, active_ref = floe.refs("contact.count", "contact.active")
    force_ref, x_ref = st.refs("force", "x")
    times = floe.refs(TIME) + st.refs(TIME)
    n = round(t_end / h)
    xs, impacts, at_start, returns, exchanges = [st.get("x")], [], [], [], []
    impulse, count, riding = 0.0, 0, False
    t = 0.0
    try:
        for k in range(n):
            point = (k + 1) * h
            while True:
                # the exchange: the structure at t (a under the force it is given) -> the floe
                if trace:
                    exchanges.append((floe.fmu.getFloat64(times[:1])[0],
                                      st.fmu.getFloat64(times[1:])[0]))
                floe.fmu.setFloat64(sinks, st.fmu.getFloat64(sources))
                if not early_return:
                    t_start, dt = k * h, h  # system.fmpy_master's step, to the bit
                else:
                    t_start, dt = t, point - t
                if approaching:
                    floe.save()
                early, reached = floe.step(t_start, dt, rollback=approaching)
                at_point = not early
                if early and approaching and reached - t_start > 2.0 * approach:
                    # take the step back and stop short of the event: same inputs, same
                    # computation, so the floe meets no event before t_e - approach
                    floe.restore()
                    early, reached = floe.step(t_start, reached - approach - t_start,
                                               rollback=True)
                    at_point = False
                j, force, t_last, gap = floe.fmu.getFloat64(outputs)
                new_count = floe.fmu.getInt32([count_ref])[0]
                now_riding = floe.fmu.getBoolean([active_ref])[0]
                impulse += j
                if new_count > count:
                    impacts += [math.nan] * (new_count - count - 1) + [t_last]
                    at_start += [False] * (new_count - count - 1) + [t_last == t_start]
                if early and trace:
                    returns.append((t_start, reached, count, new_count, t_last, riding,
                                    now_riding, gap))
                step = reached - t_start
                if early and new_count > count and t_last == reached and step > 2.0 * kick:
                    # a flight ending in an impact: the impulse arrives at the impact
                    t_kick = reached - kick
                    st.fmu.setFloat64([force_ref], [0.0])
                    st.step(t_start, t_kick - t_start)
                    st.fmu.setFloat64([force_ref], [j / (reached - t_kick)])
                    st.step(t_kick, reached - t_kick)
                    st.fmu.setFloat64([force_ref], [force])  # the connection's value again
                else:
                    st.fmu.setFloat64([force_ref], [force])
                    st.step(t_start, step)
                count, riding = new_count, now_riding
                if at_point:
                    t = point
                    break
                t = reached
            xs.append(st.fmu.getFloat64([x_ref])[0])
        if trace:
            exchanges.append((floe.fmu.getFloat64(times[:1])[0], st.fmu.getFloat64(times[1:])[0]))
    finally:
        steps = {"floe": floe.steps, "structure": st.steps}
        floe.close()
        st.close()
    result = {"time": np.arange(n + 1) * h, "x": np.array(xs), "impulse": impulse,
              "count": count, "impacts": np.array(impacts),
              "at_start": np.array(at_start, dtype=bool), "steps": steps}
    if trace:
        result["returns"] = returns
        result["exchanges"] = np.array(exchanges)
    return result


def impact_time_error(impacts: np.ndarray, reference: np.ndarray) -> tuple[float, int]:
    """Max |t - t_ref| over the impacts matched in order (the i-th with the i-th) whose time is
    known (a NaN, an impact the master could not time, is left out), and how many were matched
    with a known time."""
    m = min(len(impacts), len(reference))
    dt = np.abs(np.asarray(impacts[:m], dtype=float) - np.asarray(reference[:m], dtype=float))
    known = dt[~np.isnan(dt)]
    return (float(np.max(known)) if len(known) else math.nan), int(len(known))


def reachable_impacts(scene, t_end: float, h: float) -> np.ndarray:
    """The impact times of the monolithic run (``scene``, stepped on the grid ``k h``) with its
    Zeno sequences closed at the chatter time, as IceImpact closes them against an external
    structure: the impacts a coupled run can meet. The monolithic run itself follows each
    sequence to its end, bounces of nanoseconds no coupled structure resolves (116 impacts in
    the impacting scene's 6 s against 27 here), so matching a coupled run's impacts in order
    against those would compare unrelated impacts after the first sequence."""
    from iceimpact.simulator import Simulator

    sim = Simulator(scene)
    sim.solver.rules.follow_zeno = False
    for k in range(round(t_end / h)):
        sim.advance_to((k + 1) * h)
    return np.array([impact.t for impact in sim.impacts])


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fmus", type=Path, default=Path("dist"),
                        help="folder with IceImpact3.fmu and ModalStructure3.fmu (default: dist)")
    parser.add_argument("--t-end", type=float, default=6.0)
    parser.add_argument("--steps", type=float, nargs="+", default=[1e-2, 3e-3, 1e-3])
    args = parser.parse_args(argv)
    from iceimpact import Scene
    from iceimpact.simulator import run

    scene = Scene(drag_model=ICE["drag.model"], ice_M=ICE["ice.M"], impact_e=ICE["impact.e"],
                  structure_m=ICE["structure.m"], flow_u=FLOW_U)
    print(f"{args.t_end:g} s; x error = max |x - x_mono| / max |x_mono| at the grid points; "
          "impact times = max |t - t_ref| of the impacts matched in order with the monolithic "
          "run's impacts, its Zeno sequences closed at the chatter time; 'without those at a step "
          "start' leaves out the impacts the floe counts at the very start of a step")
    for h in args.steps:
        mono = run(scene, args.t_end, dt=h)
        reference = reachable_impacts(scene, args.t_end, h)
        peak = np.max(np.abs(mono.x))
        for master in MASTERS:
            result = early_return_master(args.fmus, args.t_end, h, master)
            m = min(len(result["x"]), len(mono.x))
            error = np.max(np.abs(result["x"][:m] - mono.x[:m])) / peak
            dt, matched = impact_time_error(result["impacts"], reference)
            real, _ = impact_time_error(result["impacts"][~result["at_start"]], reference)
            print(f"  h = {h:<6g} {master:15s} x error {error:8.2%}  impact times {dt:9.3g} s "
                  f"({matched} timed; {real:9.3g} s without those at a step start)  impacts "
                  f"{result['count']} ({np.sum(result['at_start'])} at a step start) / "
                  f"{len(reference)}  doSteps {result['steps']['floe']} + "
                  f"{result['steps']['structure']}")


if __name__ == "__main__":
    main()
