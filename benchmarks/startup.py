"""Start-up of the compiled kernels: what a fresh process pays before its first results, pure,
compiled with an empty cache and compiled with a warm one.

    python benchmarks/startup.py [--rounds N] [--quick] [--long SECONDS]

Each case runs in a fresh subprocess, which times itself (CPU time of the process and wall-clock
time):

- the core: ``import iceimpact``, then the first ``iceimpact.run(Scene(), 10.0)``;
- the FMU: ``fmpy.simulate_fmu`` of IceImpact.fmu (built fresh by ``build_fmu.build``) over
  ``STOP_TIME`` s, its extraction, instantiation, first doSteps and termination (FMPy extracts
  the FMU afresh at every call, so each run's core sits at a new path); FMPy's own import is not
  counted.

Cases: pure (``ICEIMPACT_PURE=1``; the FMU with ``ICEIMPACT_FMU_COMPILED=0``), compiled with a
cold cache (``ICEIMPACT_CACHE_DIR`` an empty folder, new for each round: numba compiles every
kernel) and compiled with a warm cache (a folder one untimed run filled: numba loads every
kernel). Each worker reports numba's cache hits and misses, which the benchmark checks against
the case. Rounds are interleaved (the machine is noisy); the table gives the best of
``--rounds`` (default 5; ``--quick``: 2) for each column. ``--long 400`` adds the FMU over 400
s, pure and warm, with the process's peak memory: what the compiled kernels save in a long run
against what numba costs to load. Prints a table and writes
``benchmarks/results/startup.json`` and ``startup.md``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
from datetime import UTC, datetime
from pathlib import Path

from tree import ROOT, load

build_fmu = load("build_fmu.py")

OUT = ROOT / "benchmarks" / "results" / "startup.json"
T_END = 10.0  # s, the core's first run
STOP_TIME = 0.01  # s, the FMU's run: 10 communication steps of 1 ms
STEP = 1e-3  # s

_CORE_WORKER = """
import json, sys, time
wall, cpu = time.perf_counter(), time.process_time()
import iceimpact
from iceimpact import Scene
wall_import, cpu_import = time.perf_counter() - wall, time.process_time() - cpu
wall, cpu = time.perf_counter(), time.process_time()
result = iceimpact.run(Scene(), %(t_end)r)
wall_run, cpu_run = time.perf_counter() - wall, time.process_time() - cpu
from iceimpact import compiled
from iceimpact.solvers.search.flight_search import COMPILED
stats = compiled.cache_stats() if COMPILED is not None else {"hits": 0, "misses": 0}
print(json.dumps({"import_cpu": cpu_import, "import_wall": wall_import, "run_cpu": cpu_run,
                  "run_wall": wall_run, "impacts": len(result.impacts),
                  "compiled": COMPILED is not None, "hits": stats["hits"],
                  "misses": stats["misses"]}))
"""

_FMU_WORKER = """
import json, resource, sys, time
import fmpy
wall, cpu = time.perf_counter(), time.process_time()
result = fmpy.simulate_fmu(%(fmu)r, stop_time=%(stop)r, output_interval=%(step)r)
wall_run, cpu_run = time.perf_counter() - wall, time.process_time() - cpu
cores = [m for name, m in sys.modules.items() if name.endswith(".solvers.search.flight_search")]
compiled = bool(cores) and cores[0].COMPILED is not None
stats = {"hits": 0, "misses": 0}
if compiled:
    # (the package's compiled module: iceimpact.compiled, under the FMU's own package name)
    stats = sys.modules[cores[0].__name__.rsplit(".", 3)[0] + ".compiled"].cache_stats()
rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # MB (Linux: kB)
print(json.dumps({"run_cpu": cpu_run, "run_wall": wall_run, "rows": len(result), "rss_mb": rss,
                  "compiled": compiled, "hits": stats["hits"], "misses": stats["misses"]}))
"""


def _worker(code: str, env: dict[str, str]) -> dict:
    done = subprocess.run([sys.executable, "-c", code], env={**os.environ, **env},
                          capture_output=True, text=True, timeout=600, cwd=ROOT)
    if done.returncode != 0:
        raise RuntimeError(f"worker failed ({env}):\n{done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def _env(case: str, cache: Path, fmu: bool) -> dict[str, str]:
    if case == "pure":
        return {"ICEIMPACT_FMU_COMPILED": "0"} if fmu else {"ICEIMPACT_PURE": "1"}
    env = {"ICEIMPACT_CACHE_DIR": str(cache), "ICEIMPACT_PURE": "0"}
    return {**env, "ICEIMPACT_FMU_COMPILED": "1"} if fmu else env


def _check(case: str, record: dict) -> None:
    """The worker ran the path and met the cache its case says (cold: all compiled, warm: all
    loaded)."""
    expected = {"pure": (False, 0, 0), "cold": (True, 0, None), "warm": (True, None, 0)}[case]
    compiled, hits, misses = expected
    ok = (record["compiled"] == compiled and (hits is None or record["hits"] == hits)
          and (misses is None or record["misses"] == misses)
          and (case == "pure" or record["hits"] + record["misses"] > 0))
    if not ok:
        raise RuntimeError(f"case {case}: the worker reported {record}")


def measure(rounds: int, fmu: Path, scratch: Path,
            long: float | None = None) -> dict[str, dict[str, list[dict]]]:
    """{"core"|"fmu"|"long": {case: [record of each round]}}, the rounds interleaved; "long"
    (``--long``) only pure and warm."""
    warm = {"core": scratch / "warm_core", "fmu": scratch / "warm_fmu"}
    warm["long"] = warm["fmu"]
    codes = {"core": _CORE_WORKER % {"t_end": T_END},
             "fmu": _FMU_WORKER % {"fmu": str(fmu), "stop": STOP_TIME, "step": STEP}}
    if long:
        codes["long"] = _FMU_WORKER % {"fmu": str(fmu), "stop": long, "step": STEP}
    for what in ("core", "fmu"):  # one untimed run fills each warm cache
        _worker(codes[what], _env("warm", warm[what], what == "fmu"))
    records: dict[str, dict[str, list[dict]]] = {w: {c: [] for c in ("pure", "cold", "warm")}
                                                 for w in codes}
    for round_ in range(rounds):
        for what, code in codes.items():
            for case in ("pure", "warm") if what == "long" else ("pure", "cold", "warm"):
                folder = warm[what] if case == "warm" else scratch / f"cold_{what}_{round_}"
                record = _worker(code, _env(case, folder, what != "core"))
                _check(case, record)
                records[what][case].append(record)
                print(f"round {round_ + 1}/{rounds} {what:<4} {case:<5} "
                      f"{record['run_cpu'] + record.get('import_cpu', 0.0):6.2f} s CPU",
                      flush=True)
    return records


CASES = {"pure": "pure", "cold": "compiled, cold cache", "warm": "compiled, warm cache"}


def best(records: list[dict], field: str) -> float:
    return min(r[field] for r in records)


def markdown(records: dict, rounds: int, long: float | None = None) -> str:
    lines = [f"Fresh processes, best of {rounds} interleaved rounds for each column; CPU time "
             "of the process / wall-clock time, in seconds. Cold: an empty cache folder (numba "
             "compiles every kernel); warm: the folder an earlier run filled (numba loads every "
             "kernel).", "",
             f"`import iceimpact`, then the first `iceimpact.run(Scene(), {T_END:g})`:", "",
             "| case | import CPU / wall | first run CPU / wall | both, CPU | kernels loaded "
             "/ compiled |", "|---|---:|---:|---:|---:|"]
    for case, name in CASES.items():
        rs = records["core"][case]
        lines.append(f"| {name} | {best(rs, 'import_cpu'):.2f} / {best(rs, 'import_wall'):.2f} "
                     f"| {best(rs, 'run_cpu'):.3f} / {best(rs, 'run_wall'):.3f} "
                     f"| {min(r['import_cpu'] + r['run_cpu'] for r in rs):.2f} "
                     f"| {rs[-1]['hits']} / {rs[-1]['misses']} |")
    lines += ["", f"`fmpy.simulate_fmu` of IceImpact.fmu over {STOP_TIME:g} s at {STEP:g} s "
              "(extraction, instantiation, the first doSteps; FMPy's import not counted):", "",
              "| case | CPU | wall | kernels loaded / compiled |", "|---|---:|---:|---:|"]
    for case, name in CASES.items():
        rs = records["fmu"][case]
        lines.append(f"| {name} | {best(rs, 'run_cpu'):.2f} | {best(rs, 'run_wall'):.2f} "
                     f"| {rs[-1]['hits']} / {rs[-1]['misses']} |")
    if long:
        lines += ["", f"The same over {long:g} s (the Figure 2 scene, "
                  f"{records['long']['pure'][-1]['rows'] - 1} steps, all outputs recorded), "
                  "the whole process's peak memory beside:", "",
                  "| case | CPU | wall | peak resident MB |", "|---|---:|---:|---:|"]
        for case in ("pure", "warm"):
            rs = records["long"][case]
            lines.append(f"| {CASES[case]} | {best(rs, 'run_cpu'):.2f} "
                         f"| {best(rs, 'run_wall'):.2f} | {best(rs, 'rss_mb'):.0f} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5, help="interleaved rounds (default 5)")
    parser.add_argument("--quick", action="store_true", help="2 rounds")
    parser.add_argument("--long", type=float, metavar="SECONDS",
                        help="also a run of the FMU this long, pure and warm (e.g. 400)")
    args = parser.parse_args(argv)
    rounds = 2 if args.quick else args.rounds
    with tempfile.TemporaryDirectory(prefix="startup_bench_") as tmp:
        scratch = Path(tmp)
        fmu = build_fmu.build(scratch / "dist")
        records = measure(rounds, fmu, scratch, args.long)
    text = markdown(records, rounds, args.long)
    print()
    print(text)
    import numba

    result = {
        "benchmark": "startup",
        "date": datetime.now(UTC).isoformat(timespec="seconds"),
        "machine": {"python": platform.python_version(), "platform": platform.platform(),
                    "numba": numba.__version__, "cpus": os.cpu_count()},
        "rounds": rounds, "t_end": T_END, "fmu_stop_time": STOP_TIME, "fmu_step": STEP,
        "long_stop_time": args.long,
        "records": records,
    }
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(result, indent=2) + "\n")
    OUT.with_suffix(".md").write_text(text)
    print(f"wrote {OUT.relative_to(ROOT)} and {OUT.with_suffix('.md').relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
