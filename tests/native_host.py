"""Shared by the tests that run the FMUs outside Python: native hosts, and a machine with no Python.

- :func:`run_empty_env` runs a host like ``env -i``;
- :func:`compile_c` builds the C hosts of ``tests/c_host``;
- :func:`ecos_binary` copies ECOS's command-line engine out of the ecospy wheel (which installs it
  without the execute bit, and inside the venv, which a machine with no Python hides);
- :data:`OMSIMULATOR`: the build of OpenModelica's OMSimulator beside the repository
  (``../shared/tools/omsimulator``), None where absent;
- :func:`without_python` wraps a command so that it runs in a private mount namespace where
  every Python installation, venv and site-packages of this machine is hidden (root only: the
  tests skip with the reason elsewhere); :func:`without_numpy` hides only the site-packages, for
  a machine with Python but no numpy.
"""

from __future__ import annotations

import glob
import os
import shutil
import stat
import subprocess
import sys
import sysconfig
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
C_HOST = ROOT / "tests" / "c_host"
_OMS = ROOT.parent / "shared" / "tools" / "omsimulator" / "bin" / "OMSimulator"
OMSIMULATOR: Path | None = _OMS if _OMS.exists() else None
OMSIMULATOR_ABSENT = ("OMSimulator is not beside the repository (../shared/tools/omsimulator/bin/"
                      "OMSimulator): the tests in OMSimulator cannot run here")


def run_empty_env(command: list[str], cwd: Path | None = None,
                  timeout: float = 300) -> subprocess.CompletedProcess:
    """Run ``command`` like ``env -i``: no environment variable at all."""
    return subprocess.run(command, env={}, cwd=cwd, capture_output=True, text=True,
                          timeout=timeout)


def compiler() -> str:
    cc = shutil.which("cc") or shutil.which("gcc")
    assert cc, "no C compiler (scripts/system-deps.sh installs gcc)"
    return cc


def compile_c(source: Path, exe: Path, *flags: str) -> Path:
    subprocess.run([compiler(), "-O2", "-Wall", "-Wextra", "-Werror", "-o", str(exe),
                    str(source), *flags], check=True)
    return exe


def parse_csv(text: str) -> dict[str, np.ndarray]:
    lines = text.strip().splitlines()
    header = lines[0].split(",")
    data = np.array([[float(x) for x in line.split(",")] for line in lines[1:]])
    return {name: data[:, i] for i, name in enumerate(header)}


def ecos_binary(folder: Path) -> Path:
    """ECOS's command-line engine, copied into ``folder`` with the execute bit."""
    ecospy = pytest.importorskip("ecospy")
    ecos = folder / "ecos"
    shutil.copy(Path(ecospy.__file__).parent / "binaries" / "ecos", ecos)
    ecos.chmod(ecos.stat().st_mode | stat.S_IXUSR)
    return ecos


def read_ecos_csv(path: Path) -> dict[str, np.ndarray]:
    lines = path.read_text().strip().splitlines()
    header = [h.strip() for h in lines[0].split(",")]
    data = np.array([[float(x) for x in line.split(",")] for line in lines[1:]])
    return {name: data[:, i] for i, name in enumerate(header)}


# A machine with no Python ---------------------------------------------------------------------
def _python_places() -> tuple[list[str], list[str]]:
    """(folders, files) that hold a Python installation, venv or site-packages here."""
    version = "{}.{}".format(*sys.version_info[:2])
    folders = set()
    for prefix in {sys.prefix, sys.base_prefix, sys.exec_prefix}:
        if prefix not in ("/usr", "/usr/local", "/"):
            folders.add(prefix)  # a venv or a Python of its own (pyenv): all of it
    folders.update(p for p in glob.glob("/usr/lib/python3*") + glob.glob("/usr/local/lib/python3*")
                   if os.path.isdir(p))
    folders.update(p for p in sysconfig.get_paths().values() if os.path.isdir(p)
                   and not p.startswith(("/usr/include", "/usr/local/include")))
    pyenv = os.path.expanduser("~/.pyenv")
    if os.path.isdir(pyenv):
        folders.add(pyenv)
    files = [p for pattern in ("/usr/bin/python3*", "/usr/local/bin/python3*", "/usr/bin/python",
                               "/usr/lib/*/libpython3*", "/usr/local/lib/libpython3*",
                               "/lib/*/libpython3*")
             for p in glob.glob(pattern) if os.path.isfile(p) and not os.path.islink(p)]
    files += [f"/usr/bin/python{version}"] if os.path.isfile(f"/usr/bin/python{version}") else []
    # hide the outermost folders only (a mount over a hidden folder's child would fail)
    outer = sorted(folders, key=len)
    kept: list[str] = []
    for folder in outer:
        if not any(folder == k or folder.startswith(k + "/") for k in kept):
            kept.append(folder)
    files = [f for f in dict.fromkeys(files)
             if not any(f.startswith(k + "/") for k in kept)]
    return kept, files


def _namespace_script(folders: list[str], files: list[str]) -> str:
    lines = ["set -e"]
    lines += [f"mount -t tmpfs -o ro none '{folder}'" for folder in folders]
    lines += [f"mount --bind /dev/null '{file}'" for file in files]
    lines.append('exec "$@"')
    return "\n".join(lines)


def _namespace_available() -> str | None:
    """None where a private mount namespace can be made, else why not."""
    if not shutil.which("unshare"):
        return "no unshare command (util-linux)"
    if os.geteuid() != 0:
        return "a private mount namespace needs root (CI runs as root)"
    done = subprocess.run(["unshare", "-m", "true"], capture_output=True, text=True)
    if done.returncode != 0:
        return f"unshare -m fails here: {done.stderr.strip()}"
    return None


def without_python(command: list[str]) -> list[str]:
    """``command`` in a private mount namespace that hides every Python of this machine, run with
    an empty environment (``env -i``); skips the test where no such namespace can be made."""
    reason = _namespace_available()
    if reason:
        pytest.skip(reason)
    folders, files = _python_places()
    return ["unshare", "-m", "sh", "-c", _namespace_script(folders, files), "hide-python",
            "env", "-i", *command]


def without_numpy(command: list[str]) -> list[str]:
    """``command`` where this machine's Python stays but no numpy or scipy is importable: every
    site-packages folder and venv is hidden (not the standard library, nor libpython)."""
    reason = _namespace_available()
    if reason:
        pytest.skip(reason)
    folders = {sys.prefix} if sys.prefix != sys.base_prefix else set()
    folders.update(p for p in (sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"],
                               *glob.glob("/usr/lib/python3/dist-packages"),
                               *glob.glob("/usr/local/lib/python3*/dist-packages"),
                               *glob.glob(f"{sys.base_prefix}/lib/python3*/site-packages"))
                   if os.path.isdir(p))
    kept: list[str] = []
    for folder in sorted(folders, key=len):
        if not any(folder == k or folder.startswith(k + "/") for k in kept):
            kept.append(folder)
    return ["unshare", "-m", "sh", "-c", _namespace_script(kept, []), "hide-numpy",
            "env", "-i", *command]
