"""Cost of one doStep of IceImpact.fmu (and IceImpact3.fmu, FMI 3.0) against a PythonFMU slave
that does no work.

    python benchmarks/fmu_overhead.py [--quick] [--repeat N] [--base COMMIT]

Both FMUs are built fresh, then simulated in this one process through FMPy's ``simulate_fmu``, the
Figure 2 scene for 400 s (``--quick``: 40 s) at a communication step of 1 ms, recording every
output at every step. The core alone (``Simulator.advance`` over the same steps, no FMI) is timed
too, so the table splits the cost into model and FMI plumbing, and so is the pure core in a fresh
process (``ICEIMPACT_PURE=1``, the path the FMU runs by default), with ``--base`` the base's too.
Prints a table and writes ``benchmarks/results/fmu_overhead.json``. Times are the best of
``--repeat`` interleaved runs, as CPU time of this process (insensitive to other load on the
machine; the ratio uses it) and as wall-clock time. ``--base COMMIT`` also builds IceImpact.fmu
from that commit (its ``build_fmu.py``, ``fmu_build`` where it has one, ``fmu_src``,
``fmu_native`` and ``pyproject.toml``, extracted with ``git archive``) and steps it in the same
interleaved runs: before and after side by side, under the same machine load.

The trivial slave (``benchmarks/trivial_fmu/TrivialSlave.py``) keeps PythonFMU's default
fmi2Get/fmi2Set path (one getter call per variable); IceImpact.fmu's slave reads its outputs in
batch calls (``iceimpact.fmi.slave_base``). The yardstick is a do-nothing slave as PythonFMU
makes it, so the benchmark checks that the trivial slave overrides none of those methods.

A second table splits a step into its FMI calls: each FMU is instantiated with FMPy's
``FMU2Slave`` (``FMU3Slave`` for IceImpact3.fmu) and stepped by hand over the first
``CALL_STEPS`` communication points (doStep timed alone), then one getReal, getInteger and
getBoolean (getFloat64, getInt32, getBoolean) of all its outputs is timed over as many calls (what
FMPy's recorder asks at every step); best of ``--repeat`` interleaved rounds, each round
continuing from where the last one stopped. IceImpact3.fmu runs the same slave behind the FMI 3.0
layer (fmu_native/fmi3.c), without early return: its row is the cost of that layer.
"""

from __future__ import annotations

import argparse
import importlib.metadata
import importlib.util
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from datetime import UTC, datetime
from pathlib import Path

from tree import ROOT, extract_commit, paths_in

HERE = Path(__file__).resolve().parent
STEP = 1e-3  # s
CALL_STEPS = 20000  # steps (and get calls) per round of the per-call table (--quick: 4000)


def _build_iceimpact(dest: Path, root: Path = ROOT) -> Path:
    """IceImpact.fmu built by ``root``'s build_fmu.py from ``root``'s sources."""
    spec = importlib.util.spec_from_file_location(f"build_fmu_{abs(hash(root))}",
                                                  root / "build_fmu.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.build(dest)


def _build_iceimpact3(dest: Path) -> Path:
    """IceImpact3.fmu (FMI 3.0) built by this tree's build_fmu.py."""
    spec = importlib.util.spec_from_file_location("build_fmu_fmi3", ROOT / "build_fmu.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.build_fmi3("IceImpact", dest)


def _check_trivial_interface() -> None:
    """The trivial slave has IceImpact's inputs and outputs (names and types), so that both
    FMUs are stepped and recorded alike."""
    from iceimpact.contract import INPUTS, OUTPUTS

    spec = importlib.util.spec_from_file_location("TrivialSlave",
                                                  HERE / "trivial_fmu" / "TrivialSlave.py")
    trivial = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(trivial)
    kinds = {trivial.Real: float, trivial.Integer: int, trivial.Boolean: bool}
    assert trivial.INPUTS == tuple(v.name for v in INPUTS), trivial.INPUTS
    assert [(n, kinds[k]) for n, k in trivial.OUTPUTS] == [(o.name, o.kind) for o in OUTPUTS]
    # PythonFMU's own fmi2Get/fmi2Set path: the yardstick is a slave as PythonFMU makes it
    for kind in ("real", "integer", "boolean", "string"):
        for method in (f"get_{kind}", f"set_{kind}"):
            assert getattr(trivial.TrivialSlave, method) is getattr(trivial.Fmi2Slave, method), (
                f"TrivialSlave overrides PythonFMU's {method}")


def _build_trivial(dest: Path) -> Path:
    from pythonfmu import FmuBuilder

    return Path(FmuBuilder.build_FMU(HERE / "trivial_fmu" / "TrivialSlave.py", dest=dest))


def _best(times: list[tuple[float, float]]) -> tuple[float, float]:
    """Smallest wall-clock and smallest CPU time (s) over repeated runs."""
    return min(w for w, _ in times), min(c for _, c in times)


def run_fmu(fmu: Path, stop_time: float) -> tuple[float, float, object]:
    """One simulate_fmu run: wall-clock and CPU time of this process (s), the result."""
    from fmpy import simulate_fmu

    wall, cpu = time.perf_counter(), time.process_time()
    result = simulate_fmu(str(fmu), start_time=0.0, stop_time=stop_time, output_interval=STEP)
    return time.perf_counter() - wall, time.process_time() - cpu, result


class CallTimer:
    """One FMU instance stepped by hand: CPU time per doStep and per round of the three gets."""

    def __init__(self, fmu: Path, name: str, guards_null: bool = True):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave
        from fmpy.fmi3 import FMU3Slave

        md = read_model_description(str(fmu))
        self.fmi3 = md.fmiVersion == "3.0"
        self.slave = (FMU3Slave if self.fmi3 else FMU2Slave)(
            guid=md.guid, unzipDirectory=extract(str(fmu)),
            modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        self.slave.instantiate()
        if self.fmi3:
            self.slave.enterInitializationMode(startTime=0.0)
        else:
            self.slave.setupExperiment(startTime=0.0)
            self.slave.enterInitializationMode()
        self.slave.exitInitializationMode()
        outputs = [v for v in md.modelVariables if v.causality == "output"]
        kinds = {"Float64": "Real", "Int32": "Integer"}
        self.vrs = {kind: [v.valueReference for v in outputs if kinds.get(v.type, v.type) == kind]
                    for kind in ("Real", "Integer", "Boolean")}
        self.k = 0  # communication points k * STEP, as simulate_fmu steps
        self.guards_null = guards_null  # the library refuses a NULL instance (IceImpact's)

    def raw_do_step(self, component=None):
        """fmi2DoStep / fmi3DoStep as a bare ctypes function of the library, its arguments
        made once (FMPy's doStep builds FMI 3.0's four result arguments at every call), on
        ``component`` (None: this instance). Called with a NULL instance, the function returns
        at once: that call's cost is ctypes' alone (8 arguments for FMI 3.0, 4 for FMI 2.0)."""
        import ctypes

        common = (ctypes.c_void_p, ctypes.c_double, ctypes.c_double)
        component = self.slave.component if component is None else component
        if not self.fmi3:
            do_step = ctypes.CFUNCTYPE(ctypes.c_int, *common, ctypes.c_int)(
                ("fmi2DoStep", self.slave.dll))
            return lambda t, h: do_step(component, t, h, 1)
        flags = [ctypes.c_bool() for _ in range(3)]
        last = ctypes.c_double()
        do_step = ctypes.CFUNCTYPE(ctypes.c_int, *common, ctypes.c_bool,
                                   *(ctypes.POINTER(ctypes.c_bool),) * 3,
                                   ctypes.POINTER(ctypes.c_double))(
            ("fmi3DoStep", self.slave.dll))
        pointers = (*map(ctypes.pointer, flags), ctypes.pointer(last))
        return lambda t, h: do_step(component, t, h, True, *pointers)

    def round(self, n: int) -> tuple[float, float, float | None, float]:
        """us per doStep (FMPy's) over the next n steps; us per doStep as a bare C call over the
        n after; us per call of it on a NULL instance (ctypes' part; None for a library that
        does not refuse a NULL instance: PythonFMU's own, the trivial slave's); us per getReal +
        getInteger + getBoolean."""
        slave, k0 = self.slave, self.k
        cpu = time.process_time()
        for k in range(k0, k0 + n):
            slave.doStep(k * STEP, (k + 1) * STEP - k * STEP)
        step = time.process_time() - cpu
        raw = self.raw_do_step()
        cpu = time.process_time()
        for k in range(k0 + n, k0 + 2 * n):
            if raw(k * STEP, (k + 1) * STEP - k * STEP) > 1:
                raise RuntimeError("doStep failed")
        raw_step = time.process_time() - cpu
        self.k = k0 + 2 * n
        null_call = None
        if self.guards_null:  # (a NULL instance: refused, said once on stderr)
            null = self.raw_do_step(component=0)
            cpu = time.process_time()
            for k in range(n):
                null(k * STEP, STEP)
            null_call = 1e6 * (time.process_time() - cpu) / n
        if self.fmi3:
            get_real, get_integer, get_boolean = (slave.getFloat64, slave.getInt32,
                                                  slave.getBoolean)
        else:
            get_real, get_integer, get_boolean = (slave.getReal, slave.getInteger,
                                                  slave.getBoolean)
        reals, integers, booleans = self.vrs["Real"], self.vrs["Integer"], self.vrs["Boolean"]
        cpu = time.process_time()
        for _ in range(n):
            get_real(reals)
            get_integer(integers)
            get_boolean(booleans)
        gets = time.process_time() - cpu
        return 1e6 * step / n, 1e6 * raw_step / n, null_call, 1e6 * gets / n

    def free(self) -> None:
        self.slave.terminate()
        self.slave.freeInstance()


def run_core(stop_time: float) -> tuple[float, float, int]:
    """The core stepped over the same communication points, no FMI: wall, CPU (s), steps."""
    from iceimpact import Scene, Simulator

    n = round(stop_time / STEP)
    sim = Simulator(Scene())
    wall, cpu = time.perf_counter(), time.process_time()
    for k in range(n):
        sim.advance((k + 1) * STEP - k * STEP, 0.1)
    return time.perf_counter() - wall, time.process_time() - cpu, n


_PURE_CORE = """
import json, sys, time
from iceimpact import Scene, Simulator
n, step = int(sys.argv[1]), float(sys.argv[2])
sim = Simulator(Scene())
wall, cpu = time.perf_counter(), time.process_time()
for k in range(n):
    sim.advance((k + 1) * step - k * step, 0.1)
print(json.dumps([time.perf_counter() - wall, time.process_time() - cpu, n]))
"""


def run_core_pure(root: Path, stop_time: float) -> tuple[float, float, int]:
    """:func:`run_core` in a fresh process on the package of ``root`` with
    ``ICEIMPACT_PURE=1``, the path the FMU runs by default: wall, CPU (s), steps."""
    env = {**os.environ, "PYTHONPATH": str(root / "fmu_src"), "ICEIMPACT_PURE": "1"}
    done = subprocess.run([sys.executable, "-c", _PURE_CORE, str(round(stop_time / STEP)),
                           repr(STEP)], capture_output=True, text=True, env=env, check=True,
                          cwd=tempfile.gettempdir())
    wall, cpu, n = json.loads(done.stdout.strip().splitlines()[-1])
    return wall, cpu, n


def _version(package: str) -> str:
    try:
        return importlib.metadata.version(package)
    except importlib.metadata.PackageNotFoundError:
        return "?"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="40 s instead of 400 s")
    parser.add_argument("--stop-time", type=float, help="simulated time, s (overrides --quick)")
    parser.add_argument("--repeat", type=int, default=1, help="runs per case, best kept")
    parser.add_argument("--base", help="also step IceImpact.fmu built from this commit")
    parser.add_argument("--output", type=Path, default=HERE / "results" / "fmu_overhead.json")
    args = parser.parse_args(argv)
    stop_time = args.stop_time or (40.0 if args.quick else 400.0)

    _check_trivial_interface()
    cases = ("IceImpact.fmu", "TrivialSlave.fmu", "Simulator.advance (core, no FMI)",
             "IceImpact3.fmu (FMI 3.0)")
    base_case = f"IceImpact.fmu at {args.base}" if args.base else None
    # the core as the FMU runs it (pure), this tree's and the base's, each in a fresh process
    pure_cases = ("Simulator.advance, pure",) + (
        (f"Simulator.advance, pure, at {args.base}",) if args.base else ())
    times: dict[str, list[tuple[float, float]]] = {case: [] for case in cases + pure_cases}
    with tempfile.TemporaryDirectory(prefix="fmu_overhead_") as tmp:
        fmus = {cases[0]: _build_iceimpact(Path(tmp) / "ice"),
                cases[1]: _build_trivial(Path(tmp) / "trivial"),
                cases[3]: _build_iceimpact3(Path(tmp) / "ice3")}
        if base_case:
            cases += (base_case,)
            times[base_case] = []
            # what building IceImpact.fmu needs, as of the base
            base_root = extract_commit(args.base, Path(tmp) / "base", paths_in(
                args.base, ("build_fmu.py", "fmu_build", "fmu_src", "fmu_native",
                            "pyproject.toml")))
            fmus[base_case] = _build_iceimpact(Path(tmp) / "ice_base", base_root)
        roots = dict(zip(pure_cases, (ROOT, base_root) if base_case else (ROOT,), strict=True))
        print(f"Figure 2 scene, {stop_time:g} s at {STEP * 1e3:g} ms, FMPy simulate_fmu "
              f"recording all outputs, best of {args.repeat}")
        steps = {}
        for _ in range(args.repeat):  # interleaved, so that all FMUs see the same machine load
            for case in (cases[1], cases[0], *cases[3:]):
                wall, cpu, result = run_fmu(fmus[case], stop_time)
                times[case].append((wall, cpu))
                steps[case] = len(result) - 1
                if case == cases[0]:
                    impacts = int(result["contact.count"][-1])  # this tree's IceImpact.fmu
            wall, cpu, steps[cases[2]] = run_core(stop_time)
            times[cases[2]].append((wall, cpu))
            for case in pure_cases:
                wall, cpu, steps[case] = run_core_pure(roots[case], stop_time)
                times[case].append((wall, cpu))
        call_steps = CALL_STEPS // 5 if args.quick else CALL_STEPS
        fmu_cases = (cases[1], cases[0], *cases[3:])
        timers = {case: CallTimer(fmus[case], f"calls{i}", guards_null=case != cases[1])
                  for i, case in enumerate(fmu_cases)}
        calls: dict[str, list[tuple[float, float]]] = {case: [] for case in fmu_cases}
        for _ in range(args.repeat):
            for case in fmu_cases:
                calls[case].append(timers[case].round(call_steps))
        for timer in timers.values():
            timer.free()
    assert len(set(steps.values())) == 1, steps
    n = steps[cases[0]]

    cases += pure_cases
    best = {case: _best(times[case]) for case in cases}
    us_wall = {case: 1e6 * best[case][0] / n for case in cases}
    us_cpu = {case: 1e6 * best[case][1] / n for case in cases}
    ratio = us_cpu[cases[0]] / us_cpu[cases[1]]

    width = max(map(len, cases))
    print(f"\n{'case':{width}s}  {'steps':>8s}  {'wall (s)':>9s}  {'us/step':>8s}  "
          f"{'us/step (CPU)':>13s}")
    for case in cases:
        print(f"{case:{width}s}  {n:8d}  {best[case][0]:9.2f}  {us_wall[case]:8.2f}  "
              f"{us_cpu[case]:13.2f}")
    print(f"\nIceImpact.fmu / TrivialSlave.fmu = {ratio:.2f}x (CPU time); the model adds "
          f"{us_cpu[cases[0]] - us_cpu[cases[1]]:.1f} us/step through FMI "
          f"(core alone {us_cpu[cases[2]]:.1f} us/step)")
    fmi3_ratio = us_cpu[cases[3]] / us_cpu[cases[0]]
    print(f"IceImpact3.fmu / IceImpact.fmu = {fmi3_ratio:.3f}x (CPU time): the FMI 3.0 layer")
    if base_case:
        print(f"at {args.base}: {us_cpu[base_case] / us_cpu[cases[1]]:.2f}x the trivial slave, "
              f"{us_cpu[base_case] - us_cpu[cases[0]]:.1f} us/step more than this tree")
    if base_case:
        print(f"the core as the FMU runs it (pure): {us_cpu[pure_cases[0]]:.2f} us/step, "
              f"{us_cpu[pure_cases[1]]:.2f} at {args.base} "
              f"({us_cpu[pure_cases[0]] / us_cpu[pure_cases[1]]:.3f}x)")
    print(f"impacts in {stop_time:g} s (this tree's IceImpact.fmu): {impacts}")

    # ctypes' part of a bare call, by FMI version (the trivial slave's: IceImpact.fmu's)
    null_call = {case: min(c[2] for c in calls[case if case != cases[1] else cases[0]])
                 for case in fmu_cases}
    us_calls = {case: {"doStep": min(c[0] for c in calls[case]),
                       "doStep (in the library)": min(c[1] for c in calls[case])
                       - null_call[case],
                       "getReal+getInteger+getBoolean": min(c[3] for c in calls[case])}
                for case in fmu_cases}
    print(f"\nper FMI call, FMU2Slave (FMU3Slave) stepped by hand over {call_steps} steps per "
          f"round (CPU us, best of {args.repeat})")
    print(f"{'case':{width}s}  {'doStep':>8s}  {'in the library':>14s}  {'3 gets':>8s}")
    for case in fmu_cases:
        print(f"{case:{width}s}  {us_calls[case]['doStep']:8.2f}  "
              f"{us_calls[case]['doStep (in the library)']:14.2f}  "
              f"{us_calls[case]['getReal+getInteger+getBoolean']:8.2f}")
    print("doStep: FMPy's FMU2Slave/FMU3Slave.doStep; in the library: the library's doStep "
          "called through a bare ctypes prototype, less the same call on a NULL instance")
    in_library = {case: us_calls[case]["doStep (in the library)"] for case in fmu_cases}
    print(f"IceImpact3.fmu / IceImpact.fmu, doStep in the library: "
          f"{in_library[cases[3]] / in_library[cases[0]]:.3f}x")

    report = {
        "benchmark": "fmu_overhead",
        "date": datetime.now(UTC).isoformat(timespec="seconds"),
        "command": "python benchmarks/fmu_overhead.py" + (" --quick" if args.quick else "")
                   + (f" --repeat {args.repeat}" if args.repeat != 1 else "")
                   + (f" --base {args.base}" if args.base else ""),
        "scene": "Figure 2 (defaults)",
        "stop_time_s": stop_time,
        "step_s": STEP,
        "steps": n,
        "repeat": args.repeat,
        "us_per_step_cpu": us_cpu,
        "us_per_step_wall": us_wall,
        "best_wall_s": {case: best[case][0] for case in cases},
        "best_cpu_s": {case: best[case][1] for case in cases},
        "ratio_iceimpact_to_trivial_cpu": ratio,
        "ratio_iceimpact_to_trivial_wall": us_wall[cases[0]] / us_wall[cases[1]],
        "ratio_fmi3_to_fmi2_cpu": fmi3_ratio,
        "ratio_fmi3_to_fmi2_dostep_cpu": (us_calls[cases[3]]["doStep"]
                                          / us_calls[cases[0]]["doStep"]),
        "ratio_fmi3_to_fmi2_dostep_in_library_cpu": in_library[cases[3]] / in_library[cases[0]],
        **({"base": args.base,
            "ratio_base_to_trivial_cpu": us_cpu[base_case] / us_cpu[cases[1]]}
           if base_case else {}),
        "impacts": impacts,
        "call_steps": call_steps,
        "us_per_call_cpu": us_calls,
        "environment": {
            "python": platform.python_version(),
            "platform": platform.platform(),
            "processor": platform.processor() or platform.machine(),
            **{pkg: _version(pkg) for pkg in ("fmpy", "pythonfmu", "numpy", "scipy")},
        },
    }
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(report, indent=2) + "\n")
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
