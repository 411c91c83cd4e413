"""Where the pure-Python path's time goes, counted instead of timed: the bytecode instructions
a run executes, before (a reference commit) and after (this tree), per impact and per function.

Timing the pure path against release 0.2.0 (``core_speed.py --pure --warm 5``) gives ratios
that move by up to 15 % between runs of the same code on this machine; a change of 1-2 % cannot be
told from noise. The number of bytecode instructions CPython executes is the same in every run
(it is counted with ``sys.settrace``'s opcode events), so it shows exactly what a change removes,
and where the rest is. It does not count what runs in C (numpy's vectorised sampling, math
functions, allocation and garbage collection), so the ratio of counts is not the ratio of times:
the table gives both the count per impact and its share of the run's own time per opcode.

    python benchmarks/pure_opcodes.py                       # the three scenes, about 1 min
    python benchmarks/pure_opcodes.py --scenes figure2 --lengths 400 --top 25

For each scene, in fresh processes with ``ICEIMPACT_PURE=1`` (the compiled flight search off)
and ``PYTHONPATH`` at each core: one untimed run (imports and caches), then the traced one.
Writes ``benchmarks/results/pure_opcodes.json`` and ``.md``.
"""

from __future__ import annotations

import argparse
import json
import platform
import subprocess
import sys
import tempfile
from datetime import UTC, datetime
from pathlib import Path

from core_speed import DT, SCENES
from tree import extract_commit

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"

#: The scenes and run lengths of docs/accuracy.md's table against 0.2.0.
DEFAULT_RUNS = (("figure2", 400.0), ("quadratic_A2", 60.0), ("heavy_floe", 30.0))

#: One traced run: opcodes per code object of the package, the untraced CPU time; JSON out.
_WORKER = """
import json, sys, time
from collections import Counter
from iceimpact import Scene, run
fields, t_end, dt = json.loads(sys.argv[1]), float(sys.argv[2]), float(sys.argv[3])
scene = Scene(**fields)
run(scene, t_end, dt=dt)  # imports, caches: not counted
cpu = float("inf")
for _ in range(3):
    begun = time.process_time()
    run(scene, t_end, dt=dt)
    cpu = min(cpu, time.process_time() - begun)
counts = Counter()

def tracer(frame, event, arg):
    if event == "call":
        frame.f_trace_opcodes = True
        frame.f_trace_lines = False
        return tracer
    if event == "opcode":
        counts[frame.f_code] += 1
    return tracer

sys.settrace(tracer)
result = run(scene, t_end, dt=dt)
sys.settrace(None)
named = Counter()
for code, n in counts.items():
    where = code.co_filename.split("iceimpact/")[-1] if "iceimpact/" in code.co_filename \\
        else "(outside the package)"
    named[where + ":" + code.co_qualname] += n
print(json.dumps({"impacts": int(len(result.impacts)), "cpu_s": cpu,
                  "opcodes": sum(counts.values()), "by_function": dict(named)}))
"""


def count(core: Path, fields: dict, t_end: float) -> dict:
    """One scene's counted run in a fresh interpreter whose ``iceimpact`` is under ``core``."""
    env = {"PYTHONPATH": str(core), "PATH": "/usr/bin:/bin", "ICEIMPACT_PURE": "1"}
    done = subprocess.run([sys.executable, "-c", _WORKER, json.dumps(fields), repr(t_end),
                           repr(DT)], capture_output=True, text=True, env=env, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"{core}: {done.stderr}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def markdown(rows: list[dict], base: str, top: int) -> str:
    lines = [f"Before: commit {base}; after: this tree; both pure Python (`ICEIMPACT_PURE=1`). "
             "`run(scene, t_end, dt=1e-2)` after an untimed one: bytecode instructions "
             "executed (sys.settrace), and the CPU time of the same run untraced (best of 3).",
             "",
             "| scene | t_end | impacts before / after | opcodes per impact before / after "
             "| opcode ratio | time ratio | ns per opcode before / after |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        b, a = r["before"], r["after"]
        lines.append(
            f"| {r['scene']} | {r['t_end']:g} s | {b['impacts']} / {a['impacts']} "
            f"| {b['opcodes'] / b['impacts']:,.0f} / {a['opcodes'] / a['impacts']:,.0f} "
            f"| {b['opcodes'] / a['opcodes']:.2f}x | {b['cpu_s'] / a['cpu_s']:.2f}x "
            f"| {1e9 * b['cpu_s'] / b['opcodes']:.1f} / {1e9 * a['cpu_s'] / a['opcodes']:.1f} |")
    for r in rows:
        a = r["after"]
        lines += ["", f"After, {r['scene']} ({r['t_end']:g} s): the {top} functions that "
                  "execute the most instructions, per impact", "",
                  "| function | opcodes per impact | share |", "|---|---:|---:|"]
        ranked = sorted(a["by_function"].items(), key=lambda kv: -kv[1])[:top]
        for name, n in ranked:
            lines.append(f"| `{name}` | {n / a['impacts']:,.1f} | {100 * n / a['opcodes']:.1f} % |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--base", default="7c9c6ad", help="reference commit (0.2.0)")
    parser.add_argument("--scenes", nargs="+", choices=list(SCENES))
    parser.add_argument("--lengths", type=float, nargs="+",
                        help="run lengths, s: each scene at each (default: 400, 60, 30 s)")
    parser.add_argument("--top", type=int, default=20, help="functions listed per scene")
    parser.add_argument("--out", type=Path, default=RESULTS / "pure_opcodes.json")
    args = parser.parse_args(argv)
    # each scene at each --lengths, else at its length in DEFAULT_RUNS (60 s if it has none)
    default_length = dict(DEFAULT_RUNS)
    scenes = args.scenes or list(default_length)
    runs = [(s, t) for s in scenes for t in (args.lengths or [default_length.get(s, 60.0)])]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        before_core = extract_commit(args.base, Path(tmp)) / "fmu_src"
        for name, t_end in runs:
            fields = SCENES[name][0]
            before = count(before_core, fields, t_end)
            after = count(ROOT / "fmu_src", fields, t_end)
            rows.append({"scene": name, "t_end": t_end, "before": before, "after": after})
            print(f"{name:14s} {t_end:6g} s  opcodes/impact "
                  f"{before['opcodes'] / before['impacts']:8,.0f} / "
                  f"{after['opcodes'] / after['impacts']:8,.0f}  "
                  f"opcode ratio {before['opcodes'] / after['opcodes']:.2f}x  "
                  f"time ratio {before['cpu_s'] / after['cpu_s']:.2f}x", flush=True)
    text = markdown(rows, args.base, args.top)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"base": args.base, "rows": rows, "python":
                                    platform.python_version(), "machine": platform.machine(),
                                    "date": datetime.now(UTC).isoformat(timespec="seconds")},
                                   indent=1) + "\n")
    args.out.with_suffix(".md").write_text(text)
    print(f"wrote {args.out} and {args.out.with_suffix('.md')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
