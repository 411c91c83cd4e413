"""Every relative link of README.md and the pages under docs/ resolves to a file of the
repository, the generated pages included: their copies are committed under docs/ and equal what
scripts/docs_hooks.py makes from today's code (``python scripts/docs_hooks.py --write``
regenerates them). About 5 s."""

from __future__ import annotations

import importlib.util
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
#: A Markdown link or image: ](target) or ](target "title").
LINK = re.compile(r"\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
FENCE = re.compile(r"^(```|~~~).*?^\1", re.MULTILINE | re.DOTALL)


def _hooks():
    spec = importlib.util.spec_from_file_location("docs_hooks", ROOT / "scripts" / "docs_hooks.py")
    hooks = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(hooks)
    return hooks


def relative_links(path: Path) -> list[str]:
    """The link targets of ``path`` that are files of the repository (no URL, no bare anchor),
    code blocks and inline code left out."""
    text = FENCE.sub("", path.read_text())
    text = re.sub(r"`[^`\n]*`", "", text)
    targets = []
    for target in LINK.findall(text):
        if re.match(r"[a-zA-Z][a-zA-Z0-9+.-]*:", target) or target.startswith("#"):
            continue
        targets.append(target.split("#", 1)[0])
    return [t for t in targets if t]


def test_every_relative_link_resolves() -> None:
    files = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
    dead = [f"{path.relative_to(ROOT)}: {target}" for path in files
            for target in relative_links(path) if not (path.parent / target).resolve().is_file()]
    assert not dead, "\n".join(dead)
    assert sum(len(relative_links(p)) for p in files) > 300  # the links were found


def test_the_generated_pages_are_committed_as_the_code_makes_them() -> None:
    stale = _hooks().stale_pages()
    assert not stale, ("regenerate: python scripts/docs_hooks.py --write\n" + "\n".join(stale))


def test_the_link_check_sees_a_dead_link(tmp_path: Path) -> None:
    page = tmp_path / "page.md"
    page.write_text("[a](missing.md#x) [b](https://example.org) [c](#here) `[d](no.md)`\n")
    assert relative_links(page) == ["missing.md"]
