"""Check the article's headline figures in about a minute: ``make verify``.

Runs, in this process (``reproduce_common.CoreRunner``: the Simulator stepped as the FMU steps
it, the FMU's numbers), the exact-solver runs of the article's Figure 2 (the reference scene,
400 s) and of Figure 13 (quadratic drag, A = 2 m^2: the lock-in case), and the lock-in window
table of ``examples/lockin.py --core``, and compares them with what the docs quote:

- every number docs/explanation/reproduction.md marks as from these two runs (``<!--
  run:linear.fig2.exact.... -->``, ``quadratic.a2.exact....``): Figure 2's 15,144 impacts, its
  impacts in the first 50 s and their frequency, sticking from 299.3 s, the decay times;
  Figure 13's impacts, intervals, frequencies and sticking;
- docs/explanation/lockin.md's window table (the Figure 13 scene over 200 s: the lock-in);
- Figure 2 through dist/IceImpact.fmu (FMPy), if built: the same measures as in process.

Prints each figure compared and exits with 3 if any differs (0 if all agree). ``make reproduce``
runs every figure through the FMU instead (minutes) and rewrites docs/img.

    python examples/verify_headlines.py
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import lockin
import reproduce_common as rc
import reproduce_linear
import reproduce_quadratic

ROOT = Path(__file__).resolve().parents[1]
REPRODUCTION = ROOT / "docs" / "explanation" / "reproduction.md"
LOCKIN = ROOT / "docs" / "explanation" / "lockin.md"
#: The runs checked: (script, its groups, case key), each with the exact solver.
RUNS = (("linear", reproduce_linear.GROUPS, "fig2"),
        ("quadratic", reproduce_quadratic.GROUPS, "a2"))
FMU = ROOT / "dist" / "IceImpact.fmu"


def measures(runner: rc.CoreRunner | rc.FmuRunner, script: str, key: str) -> dict:
    """The standard measures of the exact run of case ``key`` of ``script``, times left out."""
    groups = next(g for s, g, _ in RUNS if s == script)
    case = next(c for g in groups for c in g.cases if c.key == key)
    found = rc.standard_measures(runner.run(case, "exact"))
    for timing in ("wall_s", "cpu_s"):
        found.pop(timing, None)
    return found


def headline_numbers() -> tuple[dict, list[str], list[str]]:
    """(the measures, one line per number compared, one line per number that differs) for the
    two runs."""
    runner = rc.CoreRunner(echo=False)
    values: dict = {}
    for script, _, key in RUNS:
        values.setdefault(script, {})[key] = {"exact": measures(runner, script, key)}
    prefixes = tuple(f"{script}.{key}.exact." for script, _, key in RUNS)
    chosen = [(printed, key, unit) for printed, key, unit in rc.doc_anchors(
        REPRODUCTION.read_text()) if key.startswith(prefixes)]
    text = "\n".join(f"{printed}<!-- run:{key}{' ' + unit if unit else ''} -->"
                     for printed, key, unit in chosen)
    _, stale = rc.check_doc(text, values)
    compared = [f"{key}: {printed}{' ' + unit if unit else ''}"
                for printed, key, unit in dict.fromkeys(chosen)]
    return values, compared, stale


def fmu_equals_core(core: dict) -> bool:
    """Figure 2 through dist/IceImpact.fmu (FMPy, 400,000 steps) gives the in-process measures."""
    with rc.FmuRunner(FMU) as runner:
        return measures(runner, "linear", "fig2") == core


def lockin_table() -> bool:
    """docs/explanation/lockin.md's window table is today's run's."""
    rec = lockin.simulate_core(200.0)
    scene = lockin.Scene.from_fmi(lockin.START_VALUES)
    rows = lockin.window_rows(rec, scene.omega_n, 10.0)
    return lockin.generated_block(LOCKIN) == lockin.markdown_table(rec, rows)


def main() -> int:
    start = time.perf_counter()
    values, compared, stale = headline_numbers()
    for line in compared:
        print(f"  {line}")
    print(f"{len(compared)} numbers of {REPRODUCTION.relative_to(ROOT)} compared with the runs "
          "of Figures 2 and 13")
    for line in stale:
        print(f"DIFFERS {line}")
    same = lockin_table()
    print(f"{LOCKIN.relative_to(ROOT)}: the lock-in window table "
          f"{'is today' if same else 'DIFFERS from today'}'s run")
    ok = not stale and same
    if FMU.exists():
        through_fmu = fmu_equals_core(values["linear"]["fig2"]["exact"])
        print(f"{FMU.name}: Figure 2 through the FMU "
              f"{'gives the same measures' if through_fmu else 'DIFFERS from the in-process run'}")
        ok = ok and through_fmu
    else:
        print(f"{FMU} not built (python build_fmu.py): Figure 2 through the FMU not compared")
    print(f"{'verified' if ok else 'NOT verified'} in {time.perf_counter() - start:.0f} s")
    return 0 if ok else 3


if __name__ == "__main__":
    sys.exit(main())
