"""docs/explanation/design-loads.md's season example (its lifetime DELs and the cases the damage
comes from) is what ``examples/season_example.py`` gives today: the 50 cases of
examples/season_cases.csv, 3 repetitions of 600 s each (about 20 s on 2 cores)."""

from __future__ import annotations

from pathlib import Path

import season_example

ROOT = Path(__file__).resolve().parents[2]
DESIGN_LOADS = ROOT / "docs" / "explanation" / "design-loads.md"


def test_season_tables_are_the_scripts() -> None:
    summary = season_example.summary_of_a_run()
    assert summary["lifetime"]["complete"]
    assert season_example.generated_block(DESIGN_LOADS) == season_example.tables(summary), (
        "regenerate: python examples/season_example.py --write-doc "
        "docs/explanation/design-loads.md")
