"""What the FMUs run on and in, written once: the compatibility box of README.md and
docs/index.md, and the limits of the page each FMU carries (documentation/index.html).

The facts are those the tests establish (tests/fmu/, tests/system/) and the documentation
explains (docs/how-to/hand-over-the-fmu.md, docs/how-to/run-in-hosts.md,
docs/how-to/use-early-return.md, docs/explanation/fmu-loader.md). The box is kept in the two
Markdown files between :data:`BEGIN` and :data:`END`; ``python -m fmu_build.compatibility``
rewrites it there, and tests/fmu/test_documentation.py checks that both hold :func:`markdown_box`.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

from .layout import ROOT

#: The FMI versions and the FMU of each (Co-Simulation only: no Model Exchange).
FMI_FMUS = (("2.0", "IceImpact.fmu"), ("3.0", "IceImpact3.fmu"))
#: The one platform built and tested, and the binaries folders of FMI 2.0 and FMI 3.0.
PLATFORM = "Linux x86_64"
BINARIES = ("binaries/linux64", "binaries/x86_64-linux")
#: The Python versions the default FMU runs with (a Python host's own, or the loader's choice).
PYTHONS = ("3.11", "3.12", "3.13")
#: The standalone build as measured: ``python build_fmu.py --standalone`` took 1 min 53 s of wall
#: time for all eight FMUs and the SSP, and dist/standalone/IceImpact.fmu is 60.8 MB (10^6 bytes).
STANDALONE_MINUTES = 2
STANDALONE_MB = 61


@dataclass(frozen=True)
class Master:
    """A co-simulation master: the FMUs it runs here and what early return gives in it."""

    name: str
    fmus: str
    early_return: str


#: The masters tested (docs/how-to/run-in-hosts.md).
MASTERS = (
    Master("FMPy", "both", "yes: `simulate_fmu(..., early_return_allowed=True)` on IceImpact3.fmu"),
    Master("fmusim", "both", "yes: `fmusim --early-return-allowed` on IceImpact3.fmu"),
    Master("ECOS (ecospy)", "both; the coupled system (SSP) with IceImpact.fmu", "no"),
    Master("OMSimulator", "both; the coupled system (SSP) with IceImpact.fmu", "no"),
    Master("libcosim (libcosimpy)", "IceImpact.fmu only (it loads FMI 1.0 and 2.0)", "no"),
    Master("a C master", "both (tests/c_host/host.c, host3.c)",
           "yes, if it sets `earlyReturnAllowed`"),
)

#: Where the box sits in README.md and docs/index.md.
BEGIN = "<!-- compatibility box: written by python -m fmu_build.compatibility -->"
END = "<!-- end of the compatibility box -->"
#: The files holding the box, and the prefix of their links into docs/.
BOX_FILES = (("README.md", "docs/"), ("docs/index.md", ""))


def platform_text(link_root: str = "docs/") -> str:
    """What the FMUs run on, and why not elsewhere (Markdown)."""
    return (f"{PLATFORM} only (`{BINARIES[0]}`, `{BINARIES[1]}`); Windows and macOS are not "
            "built or tested: the loader and the standalone runtime would have to be built for "
            "them, and PythonFMU's `binaries/win64` library in the FMI 2.0 FMU, without this "
            "project's loader, needs a Python 3.11 with numpy and scipy on the `PATH` "
            f"([why]({link_root}explanation/fmu-loader.md#windows-and-macos))")


def python_text(link_root: str = "docs/") -> str:
    """What the FMUs need on the machine (Markdown)."""
    versions = ", ".join(PYTHONS[:-1]) + " or " + PYTHONS[-1]
    return (f"the host's Python {versions} with numpy >= 1.24 and scipy >= 1.10; or the "
            "standalone build (`python build_fmu.py --standalone`), which brings its own: it "
            "needs a Python built with `--enable-shared`, its headers and a C compiler, takes "
            f"about {STANDALONE_MINUTES} minutes and is about {STANDALONE_MB} MB per FMU "
            f"([which to hand over]({link_root}how-to/hand-over-the-fmu.md))")


def markdown_box(link_root: str = "docs/") -> str:
    """The compatibility box as Markdown; ``link_root`` is the path from the file to docs/."""
    fmi = " and ".join(f"{version} Co-Simulation (`{name}`)" for version, name in FMI_FMUS)
    rows = [
        "| compatibility | |",
        "|---|---|",
        f"| FMI | {fmi}; no Model Exchange |",
        f"| platform | {platform_text(link_root)} |",
        f"| Python | {python_text(link_root)} |",
    ]
    masters = ["| master | runs | early return (a step ends at each impact) |",
               "|---|---|---|"]
    masters += [f"| {m.name} | {m.fmus} | {m.early_return} |" for m in MASTERS]
    note = ("Early return is FMI 3.0's, in the masters that allow it; it does nothing with "
            "`coupling.scheme = 2`, the scheme of the Jacobi masters (ECOS, libcosim, "
            "OMSimulator), which run the coupled system with the FMI 2.0 FMUs here "
            f"([Use early return]({link_root}how-to/use-early-return.md), "
            f"[Run it in each host]({link_root}how-to/run-in-hosts.md)).")
    return "\n".join([BEGIN, "", *rows, "", *masters, "", note, "", END]) + "\n"


def replace_box(text: str, box: str) -> str:
    """``text`` with the part from :data:`BEGIN` to :data:`END` replaced by ``box``."""
    start, end = text.index(BEGIN), text.index(END) + len(END) + 1
    return text[:start] + box + text[end:]


def write_boxes(root: Path = ROOT) -> list[Path]:
    """Rewrite the box in README.md and docs/index.md; the files changed."""
    changed = []
    for name, link_root in BOX_FILES:
        path = root / name
        text = path.read_text()
        new = replace_box(text, markdown_box(link_root))
        if new != text:
            path.write_text(new)
            changed.append(path)
    return changed


if __name__ == "__main__":
    for path in write_boxes():
        print(path)
    sys.exit(0)
