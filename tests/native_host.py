"""Shared by the tests that run the FMUs outside Python: native hosts, and a machine with no Python.

- :func:`run_empty_env` runs a host like ``env -i``;
- :func:`compile_c` builds the C hosts of ``tests/c_host``;
- :func:`ecos_binary` copies ECOS's command-line engine out of the ecospy wheel (which installs it
  without the execute bit, and inside the venv, which a machine with no Python hides);
- :data:`OMSIMULATOR`: the build of OpenModelica's OMSimulator beside the repository
  (``../shared/tools/omsimulator``), None where absent; :data:`FMUSIM`, likewise fmusim
  (``../shared/tools/fmusim``, its runtime packages from scripts/system-deps.sh), and
  :data:`FMUCHECK`, the compliance checker (``../shared/tools/fmucheck``);
- :func:`without_python` wraps a command so that it runs in a private mount namespace where
  every Python installation, venv and site-packages of this machine is hidden (root only: the
  tests skip with the reason elsewhere); :func:`without_numpy` hides only the site-packages, for
  a machine with Python but no numpy; :func:`partial_site` makes a site-packages folder with some
  of the requirements, or too old ones;
- :func:`venv_for` makes a venv of another Python of this machine (3.12, 3.13) with numpy and
  scipy, and :func:`only_python` runs a command on this machine made into one whose only Python
  is that one, as Ubuntu 24.04 (3.12) or Debian 13 (3.13) install it.
"""

from __future__ import annotations

import fcntl
import glob
import hashlib
import importlib
import json
import os
import re
import shutil
import stat
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
C_HOST = ROOT / "tests" / "c_host"
_OMS = ROOT.parent / "shared" / "tools" / "omsimulator" / "bin" / "OMSimulator"
OMSIMULATOR: Path | None = _OMS if _OMS.exists() else None
OMSIMULATOR_ABSENT = ("OMSimulator is not beside the repository (../shared/tools/omsimulator/bin/"
                      "OMSimulator): the tests in OMSimulator cannot run here")
_FMUSIM = ROOT.parent / "shared" / "tools" / "fmusim"
#: fmusim, the FMI standard's reference C master, as it is (``fmusim``: a state saved to a file
#: is freed by the handle itself) and with that fixed (``fmusim-statefix``); None where absent
FMUSIM: Path | None = _FMUSIM / "fmusim" if (_FMUSIM / "fmusim").exists() else None
FMUSIM_STATEFIX: Path | None = (_FMUSIM / "fmusim-statefix"
                                if (_FMUSIM / "fmusim-statefix").exists() else None)
FMUSIM_ABSENT = ("fmusim is not beside the repository (../shared/tools/fmusim): the tests in "
                 "fmusim cannot run here")
#: fmuCheck, the FMI standard's compliance checker (FMI 1.0 and 2.0), None where absent
_FMUCHECK = ROOT.parent / "shared" / "tools" / "fmucheck" / "fmuCheck.linux64"
FMUCHECK: Path | None = _FMUCHECK if _FMUCHECK.exists() else None
FMUCHECK_ABSENT = ("fmuCheck is not beside the repository (../shared/tools/fmucheck/"
                   "fmuCheck.linux64): the test in fmuCheck cannot run here")


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


def _site_places() -> list[str]:
    """The site-packages folders and venvs of this machine's Pythons (outermost only)."""
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
    return kept


def without_numpy(command: list[str]) -> list[str]:
    """``command`` where this machine's Python stays but no numpy or scipy is importable: every
    site-packages folder and venv is hidden (not the standard library, nor libpython)."""
    reason = _namespace_available()
    if reason:
        pytest.skip(reason)
    return ["unshare", "-m", "sh", "-c", _namespace_script(_site_places(), []), "hide-numpy",
            "env", "-i", *command]


# Other Pythons of this machine (3.12, 3.13) -----------------------------------------------------
#: Where the tests keep the venvs they make for other Pythons (reused while their key matches).
TEST_PYTHONS = Path(tempfile.gettempdir()) / "iceimpact-test-pythons"


def other_python(version: str) -> Path | None:
    """The interpreter of CPython ``version`` ("3.12"): pyenv's newest ``<version>.*``
    (``$PYENV_ROOT``, else ``~/.pyenv``), else ``python<version>`` on the PATH; None if absent."""
    root = Path(os.environ.get("PYENV_ROOT") or Path.home() / ".pyenv")
    found = sorted((p for p in (root / "versions").glob(f"{version}.*")
                    if re.fullmatch(rf"{re.escape(version)}\.\d+", p.name)
                    and (p / "bin" / f"python{version}").exists()),
                   key=lambda p: int(p.name.rsplit(".", 1)[1]))
    if found:
        return found[-1] / "bin" / f"python{version}"
    which = shutil.which(f"python{version}")
    return Path(which) if which else None


def python_facts(python: Path) -> dict:
    """prefix, version, its shared libpython (None without one) and site-packages folder."""
    script = ("import json, sys, sysconfig, os; v = sysconfig.get_config_var; "
              "lib = os.path.join(v('LIBDIR') or '', v('INSTSONAME') or ''); "
              "print(json.dumps({'prefix': sys.base_prefix, 'version': '%d.%d' % "
              "sys.version_info[:2], 'libpython': lib if v('Py_ENABLE_SHARED') and "
              "os.path.isfile(lib) else None, 'site': sysconfig.get_paths()['purelib']}))")
    done = subprocess.run([str(python), "-I", "-c", script], capture_output=True, text=True,
                          timeout=60, check=True)
    return json.loads(done.stdout)


def venv_for(version: str, packages: dict[str, str]) -> Path:
    """A venv of CPython ``version`` with ``packages`` ({name: version}) installed by pip: its
    interpreter. Made once under :data:`TEST_PYTHONS` and reused; skips the test with the reason
    where the interpreter is absent or pip cannot install them."""
    python = other_python(version)
    if python is None:
        pytest.skip(f"no Python {version} on this machine (pyenv install {version}, or "
                    f"python{version} on the PATH)")
    pins = [f"{name}=={pin}" for name, pin in sorted(packages.items())]
    key = hashlib.sha256("\n".join([str(python.resolve()), *pins]).encode()).hexdigest()[:12]
    venv = TEST_PYTHONS / f"python{version}-{key}"
    ready = venv / "ready"
    TEST_PYTHONS.mkdir(parents=True, exist_ok=True)
    with open(TEST_PYTHONS / f"{venv.name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # one maker at a time
        if not ready.exists():
            shutil.rmtree(venv, ignore_errors=True)
            steps = ([str(python), "-m", "venv", str(venv)],
                     [str(venv / "bin" / "python"), "-m", "pip", "install", "-q", *pins])
            for step in steps:
                done = subprocess.run(step, capture_output=True, text=True, timeout=600)
                if done.returncode != 0:
                    shutil.rmtree(venv, ignore_errors=True)
                    pytest.skip(f"cannot make a Python {version} venv with {', '.join(pins)}: "
                                f"{' '.join(step[:4])} failed: {done.stderr.strip()[-500:]}")
            ready.write_text("\n".join(pins) + "\n")
    return venv / "bin" / "python"


def _overlay_available(scratch: Path) -> str | None:
    """None where an overlay file system can be mounted in a private mount namespace."""
    reason = _namespace_available()
    if reason:
        return reason
    for name in ("lower", "upper", "work", "mnt"):
        (scratch / name).mkdir(parents=True, exist_ok=True)
    done = subprocess.run(
        ["unshare", "-m", "mount", "-t", "overlay", "overlay", "-o",
         f"lowerdir={scratch}/lower,upperdir={scratch}/upper,workdir={scratch}/work",
         str(scratch / "mnt")], capture_output=True, text=True)
    if done.returncode != 0:
        return f"no overlay file system here: {done.stderr.strip()}"
    return None


def _system_library_folder() -> Path:
    """The folder the dynamic linker searches by default for a library not in its cache."""
    multiarch = sysconfig.get_config_var("MULTIARCH")
    for folder in (f"/usr/lib/{multiarch}" if multiarch else None, "/usr/lib64", "/usr/lib"):
        if folder and os.path.isdir(folder):
            return Path(folder)
    return Path("/usr/lib")


def _hidden_around(folder: str, keep: str) -> list[str]:
    """The folders to hide so that everything in ``folder`` is hidden but ``keep`` inside it."""
    hidden, current = [], Path(folder)
    for part in Path(keep).relative_to(folder).parts:
        hidden += [str(p) for p in sorted(current.iterdir())
                   if p.name != part and p.is_dir() and not p.is_symlink()]
        current = current / part
    return hidden


def only_python(command: list[str], python: Path, site_packages: Path, scratch: Path, *,
                others: str = "hidden") -> list[str]:
    """``command`` with an empty environment on this machine made into one whose only Python with
    numpy and scipy is ``python`` (another CPython, e.g. pyenv's 3.12), installed as a
    distribution installs it: its libpython is where the dynamic linker finds it by default (an
    overlay adds a link to it in the system's library folder, since pyenv's lib folder is on no
    search path) and ``site_packages`` (a venv's, with numpy and scipy) is its site-packages
    folder. The other Pythons, venvs and site-packages are hidden (``others="hidden"``, as
    :func:`without_python` does), or only their site-packages and venvs (``others="no
    packages"``, as :func:`without_numpy` does). ``scratch`` holds the overlay's folders. Skips
    the test where no such namespace can be made, or ``python`` has no shared libpython."""
    reason = _overlay_available(scratch / "probe")
    if reason:
        pytest.skip(reason)
    facts = python_facts(python)
    if facts["libpython"] is None:
        pytest.skip(f"{python} has no shared libpython (built without --enable-shared): a "
                    "native host cannot start it")
    prefix = str(Path(facts["prefix"]).resolve())
    library = Path(facts["libpython"]).resolve()
    folders, files = _python_places() if others == "hidden" else (_site_places(), [])
    kept_folders: list[str] = []
    for folder in folders:
        if prefix == folder or prefix.startswith(folder + "/"):
            kept_folders += _hidden_around(folder, prefix)
        elif not folder.startswith(prefix + "/"):
            kept_folders.append(folder)
    files = [f for f in files if Path(f).resolve() != library]
    system = _system_library_folder()
    upper, work = scratch / "upper", scratch / "work"
    for folder in (upper, work):
        shutil.rmtree(folder, ignore_errors=True)
        folder.mkdir(parents=True)
    (upper / library.name).symlink_to(library)
    lines = ["set -e",
             f"mount -t overlay overlay -o lowerdir='{system}',upperdir='{upper}',"
             f"workdir='{work}' '{system}'"]
    lines += [f"mount --bind /dev/null '{file}'" for file in files]
    lines += [f"mount -t tmpfs -o ro none '{folder}'" for folder in kept_folders]
    lines += [f"mount --bind '{site_packages}' '{facts['site']}'", 'exec "$@"']
    return ["unshare", "-m", "sh", "-c", "\n".join(lines), "only-python", "env", "-i", *command]


# A machine whose Python has some of the requirements ---------------------------------------------
def partial_site(folder: Path, **packages: str | None) -> Path:
    """A site-packages folder with some of the FMU's requirements: ``numpy="real"`` links this
    Python's numpy into it (hard links, so that it stays visible where the venv is hidden),
    ``scipy="1.9.3"`` makes a stand-in package of that version (its ``__version__`` and
    dist-info, nothing else), None leaves it out."""
    folder.mkdir(parents=True, exist_ok=True)
    for name, version in packages.items():
        if version is None:
            continue
        if version == "real":
            module = importlib.import_module(name)
            source = Path(module.__file__).parent
            for entry in source.parent.iterdir():
                if entry.name == name or entry.name == f"{name}.libs" or (
                        entry.name.startswith(f"{name}-") and entry.name.endswith(".dist-info")):
                    _link_tree(entry, folder / entry.name)
            continue
        (folder / name).mkdir()
        (folder / name / "__init__.py").write_text(f'__version__ = "{version}"\n')
        info = folder / f"{name}-{version}.dist-info"
        info.mkdir()
        (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: {version}\n")
    return folder


def _link_tree(source: Path, target: Path) -> None:
    def link(src: str, dst: str) -> None:
        try:
            os.link(src, dst)
        except OSError:
            shutil.copy2(src, dst)

    if source.is_dir():
        shutil.copytree(source, target, copy_function=link, symlinks=True)
    else:
        link(str(source), str(target))
