"""The benchmarks' access to the repository: this tree's root, files of this tree outside
benchmarks/ (the tests' independent references, the examples' masters, build_fmu.py) as modules,
and a reference commit's files for the benchmarks that compare a base commit with this tree.

The tests, the examples and the repository's root are folders of scripts, not packages: a file of
theirs is imported here by its path, once, under its file's name."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
import tarfile
from collections.abc import Iterable
from io import BytesIO
from pathlib import Path
from types import ModuleType

#: The repository's root (this tree).
ROOT = Path(__file__).resolve().parents[1]


def load(relative: str, root: Path = ROOT) -> ModuleType:
    """The module of the file ``root / relative`` (for example ``tests/ode_reference.py``),
    executed once per process and registered in ``sys.modules`` under its file's name when
    ``root`` is this tree (under a name of its own for another tree), so that a module loaded
    later that imports it by that name (``from system import ...``) gets this one. A module that
    imports a sibling needs that sibling loaded first."""
    path = (root / relative).resolve()
    name = path.stem if root == ROOT else f"{path.stem}_{abs(hash(str(path)))}"
    module = sys.modules.get(name)
    if module is not None and Path(module.__file__).resolve() == path:
        return module
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    return module


def extract_commit(commit: str, dest: Path, paths: Iterable[str] = ("fmu_src",)) -> Path:
    """The files and folders ``paths`` of ``commit`` (any name git knows: a hash, a tag, a
    branch), extracted under ``dest`` (made if missing) as they are in that commit, with
    ``git archive``; returns ``dest``. Raises CalledProcessError when git knows no such commit
    or the commit has no such path."""
    blob = subprocess.run(["git", "-C", str(ROOT), "archive", commit, *paths],
                          check=True, capture_output=True).stdout
    dest.mkdir(parents=True, exist_ok=True)
    with tarfile.open(fileobj=BytesIO(blob)) as tar:
        tar.extractall(dest, filter="data")
    return dest


def paths_in(commit: str, paths: Iterable[str]) -> list[str]:
    """Those of ``paths`` that ``commit`` has (a build made of a base before a folder existed
    extracts without it)."""
    listed = subprocess.run(["git", "-C", str(ROOT), "ls-tree", "--name-only", commit, *paths],
                            check=True, capture_output=True, text=True).stdout.split()
    return [p for p in paths if p in listed]
