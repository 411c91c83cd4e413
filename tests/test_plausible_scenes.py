"""Random engineering-plausible scenes over every feature run soundly or are refused up front
naming the limit (tests/plausible_scenes.py says what is drawn and what is checked)."""

from __future__ import annotations

import pytest

from plausible_scenes import check, draw

#: make test's draw: seeds 0 to 199, in groups (a failure names its seed)
GROUPS, PER_GROUP = 10, 20
#: the slow search's draw: seeds 0 to 9,999
SLOW_SEEDS = 10_000


def _check_seeds(seeds, fmus) -> list[str]:
    faults = []
    for seed in seeds:
        fault = check(draw(seed), fmus)
        if fault is not None:
            faults.append(f"seed {seed}: {fault}")
    return faults


@pytest.fixture(scope="module")
def fmus(fmu, fmu3):
    return fmu, fmu3


@pytest.mark.parametrize("group", range(GROUPS))
def test_plausible_scenes_run_soundly(group, fmus):
    seeds = range(group * PER_GROUP, (group + 1) * PER_GROUP)
    faults = _check_seeds(seeds, fmus)
    assert not faults, "\n".join(faults)


def test_the_draw_covers_every_feature():
    """The 200 seeds of make test draw every kind of structure with every method it takes, both
    drag laws, plastic and elastic impacts, the Morison terms, several modes, both masters of the
    external structure and FMU runs."""
    cases = [draw(seed) for seed in range(GROUPS * PER_GROUP)]
    kinds = {(c.kind, c.scene["solver_method"]) for c in cases}
    assert kinds == {("sdof", 1), ("sdof", 2), ("sdof", 3), ("modal", 1), ("modal", 2),
                     ("modal", 3), ("external", 1)}
    assert {c.scene["drag_model"] for c in cases} == {1, 2}
    assert {c.scene["impact_e"] for c in cases} >= {0.0, 1.0}
    assert any("structure_Ca" in c.scene for c in cases)
    assert any(c.scene.get("structure_modes", 1) == 3 for c in cases)
    assert {c.scheme for c in cases if c.kind == "external"} == {"gauss-seidel", "jacobi"}
    assert sum(c.fmu for c in cases) >= 5


@pytest.mark.slow
def test_ten_thousand_plausible_scenes_run_soundly(fmus):
    faults = _check_seeds(range(SLOW_SEEDS), fmus)
    assert not faults, f"{len(faults)} of {SLOW_SEEDS}:\n" + "\n".join(faults[:50])
