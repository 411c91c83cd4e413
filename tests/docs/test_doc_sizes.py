"""The size of IceImpact.fmu that docs/how-to/hand-over-the-fmu.md quotes is the size of the FMU
``python build_fmu.py`` makes today (packed and extracted, to the quoted digit)."""

from __future__ import annotations

import re
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
HAND_OVER = ROOT / "docs" / "how-to" / "hand-over-the-fmu.md"


def test_the_quoted_fmu_size_is_the_build(fmu: Path) -> None:
    row = next(line for line in HAND_OVER.read_text().splitlines()
               if line.startswith("| size |"))
    sizes = re.match(r"\| size \| ([\d.]+) MB \(([\d.]+) MB extracted\)", row)
    packed, extracted = (float(n) for n in sizes.groups())
    with zipfile.ZipFile(fmu) as z:
        unpacked = sum(info.file_size for info in z.infolist())
    assert abs(fmu.stat().st_size / 1e6 - packed) <= 0.05, fmu.stat().st_size
    assert abs(unpacked / 1e6 - extracted) <= 0.05, unpacked
