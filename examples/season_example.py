"""The illustrative season of docs/explanation/design-loads.md: its lifetime DELs and the cases
the damage comes from, as Markdown tables.

Runs ``examples/season_cases.csv`` as ``iceimpact loads examples/season_cases.csv --t-end 600
--transient 60 --life 25`` does (50 cases, 3 repetitions each, about a minute on 2 cores) and
prints the two tables the page quotes: the lifetime DEL for each Wöhler exponent (at 1 Hz and for
1e7 cycles) and the five cases with the largest damage share at m = 4, with the spread of their
repetitions' DELs and their shares at m = 3, 4 and 10.

    python examples/season_example.py                      # print the tables
    python examples/season_example.py --summary season.json # from a season already run
    python examples/season_example.py --write-doc docs/explanation/design-loads.md

tests/docs/test_doc_numbers.py (``-m slow``) compares the page's block with a fresh run.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from doc_blocks import begin, read_block, write_block

from iceimpact.seasons import load_cases, run_season

ROOT = Path(__file__).resolve().parents[1]
CASES = ROOT / "examples" / "season_cases.csv"
T_END, TRANSIENT, LIFE = 600.0, 60.0, 25.0
#: The exponents of the lifetime table, and of the share columns.
EXPONENTS, SHARES = ("3", "4", "5", "10"), ("3", "4", "10")
#: How many cases the second table lists (largest damage share at m = 4 first).
TOP = 5
BEGIN = begin("season_example.py")


def summary_of_a_run(workers: int | None = None) -> dict[str, Any]:
    """The season's summary (PREFIX.json's content) from a fresh run of every case."""
    table = load_cases(CASES, t_end=T_END, transient=TRANSIENT)
    _, summary = run_season(table, LIFE, workers=workers, progress=False)
    return summary


def case_label(parameters: dict[str, Any]) -> str:
    return (f"u = {parameters['flow.u']:g} m/s, M = {parameters['ice.M']:g} kg, "
            f"e = {parameters['impact.e']:g}")


def tables(summary: dict[str, Any]) -> str:
    """The two Markdown tables of the page, from a season summary."""
    life = summary["lifetime"]
    lines = ["| Wöhler exponent m | " + " | ".join(EXPONENTS) + " |",
             "|---" * (len(EXPONENTS) + 1) + "|",
             "| lifetime DEL at 1 Hz (N) | "
             + " | ".join(f"{life['del_1Hz_N'][m]:.1f}" for m in EXPONENTS) + " |",
             "| lifetime DEL for 1e7 cycles (N) | "
             + " | ".join(f"{life['del_1e7_N'][m]:.1f}" for m in EXPONENTS) + " |",
             "",
             "The cases the damage comes from (m = 4; `damage_share`), with the spread of the "
             "three",
             "repetitions' own 1 Hz DELs:",
             "",
             "| case | hours per year | DEL m=4, 1 Hz (N) | repetitions: min-max (N) | "
             + " | ".join(f"share m={m}" for m in SHARES) + " |",
             "|---" * (4 + len(SHARES)) + "|"]
    cases = sorted(summary["cases"], key=lambda c: -c["damage_share"]["4"])[:TOP]
    for c in cases:
        spread = c["del_1Hz_spread_N"]["4"]
        lines.append(f"| {case_label(c['parameters'])} | {c['hours_per_year']:.3g} | "
                     f"{c['del_1Hz_N']['4']:.1f} | {spread['min']:.1f}-{spread['max']:.1f} | "
                     + " | ".join(f"{100 * c['damage_share'][m]:.1f} %" for m in SHARES) + " |")
    return "\n".join(lines)


def generated_block(path: Path) -> str:
    """This script's block currently in ``path``."""
    return read_block(path, BEGIN)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--summary", type=Path, help="a season's PREFIX.json instead of a run")
    parser.add_argument("--workers", type=int, default=None, help="default: all cores")
    parser.add_argument("--write-doc", type=Path, metavar="MD",
                        help="rewrite this script's block of MD "
                             "(docs/explanation/design-loads.md)")
    args = parser.parse_args(argv)
    summary = (json.loads(args.summary.read_text()) if args.summary
               else summary_of_a_run(args.workers))
    text = tables(summary)
    print(text)
    if args.write_doc is not None:
        changed = write_block(args.write_doc, BEGIN, text)
        print(f"{args.write_doc}: {'rewritten' if changed else 'unchanged'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
