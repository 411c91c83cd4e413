"""docs/explanation/architecture.md lists every module of the package, the slaves, the FMU's
start-up and the build, and names no module that does not exist: a newcomer finds any piece by
its name there."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "explanation" / "architecture.md"


def modules() -> set[str]:
    """Every module, as the page names it: its path under fmu_src/ or from the repository's
    root (build_fmu.py, fmu_build/)."""
    found = {str(p.relative_to(ROOT / "fmu_src")) for p in (ROOT / "fmu_src").rglob("*.py")}
    found |= {str(p.relative_to(ROOT)) for p in (ROOT / "fmu_build").rglob("*.py")}
    found.add("build_fmu.py")
    return {m for m in found if "__pycache__" not in m}


def listed() -> set[str]:
    """The modules in the page's table of modules (the first column, in backticks)."""
    table = PAGE.read_text().split("## Every module", 1)[1].split("\n## ", 1)[0]
    return set(re.findall(r"^\| `([^`]+\.py)` \|", table, flags=re.MULTILINE))


def test_every_module_is_listed():
    missing = sorted(modules() - listed())
    assert not missing, f"modules missing from {PAGE.name}'s 'Every module': {missing}"


def test_every_listed_module_exists():
    stale = sorted(listed() - modules())
    assert not stale, f"{PAGE.name} lists modules that do not exist: {stale}"
