"""Work-arounds for two defects of PythonFMU 0.7.0's native library (binaries/*/IceImpact.so).

Both live here, with their explanation, so that the slave stays FMI plumbing only. Each is a
no-op where the defect cannot occur.
"""

from __future__ import annotations

import ctypes
import os
import sys
from typing import Any

# Where FMU libraries lie in an extracted FMU (FMI 2.0, FMI 3.0); those that export
# finalizePythonInterpreter are PythonFMU's.
_FMU_LIBRARIES = ("/binaries/linux64/", "/binaries/x86_64-linux/")
# Libraries (paths of loaded PythonFMU libraries) already guarded below.
_GUARDED_LIBRARIES: set[str] = set()


def hold_module_dict(module_globals: dict[str, Any]) -> None:
    """Give back the reference to a slave module's dictionary that each instantiation steals.

    PythonFMU 0.7.0's native loader (findClass in PySlaveInstance.cpp) runs the slave module's
    source a second time for every fmi2Instantiate and then calls Py_DECREF on the *borrowed*
    module dictionary: each instantiation steals one reference from it. A module whose source
    PythonFMU re-executes calls this first thing at module level (so also when the rest of the
    body fails), once per execution, and the dictionary never runs out of references.

    The reference is given back as a bare increment of the count, owned by nobody. Keeping
    ``module_globals`` in a container instead (the earlier version appended it to a list in the
    dictionary) only looks balanced: the count matches while the container lives, but when the
    container is released, at interpreter shutdown at the latest, it releases every reference it
    holds, one more than was counted per instantiation, and frees the dictionary while the module
    still uses it; the further decrements then write into freed memory and corrupt the heap.
    The increment leaks at most one dictionary per module, which lives as long as the process.
    """
    ctypes.pythonapi.Py_IncRef(ctypes.py_object(module_globals))


def guard_native_exit() -> None:
    """Work around a use-after-free at process exit in PythonFMU 0.7.0's native library.

    The library keeps the embedded interpreter in a static ``std::shared_ptr<PyState>``. At
    ``exit()`` the C++ static destructor of that pointer runs first (it finalizes Python and frees
    the PyState), then the library's ``__attribute__((destructor))`` assigns ``nullptr`` to the
    already destroyed pointer, which decrements a counter inside the freed block and corrupts the
    malloc free lists. The process then aborts or segfaults in a later ``free`` at exit (with
    numpy/scipy loaded: in libgfortran's exit-time ``close_units``). The library is never really
    unloaded (its GNU_UNIQUE symbols make it NODELETE), so this happens at process exit whether or
    not the host calls ``dlclose``.

    Every PythonFMU library in the process has the defect, ours and those of other FMUs a host
    loads beside it (an FMU library lies under ``binaries/linux64/`` or, FMI 3.0,
    ``binaries/x86_64-linux/``), so every one found is
    guarded, not only IceImpact's.

    The fix: for each loaded copy of such a library, register ``finalizePythonInterpreter``
    (exported by the library) with ``__cxa_atexit``. Being registered after the library's static
    constructors, it runs before the static destructor and releases the PyState while the pointer is
    still alive; the destructor and the library destructor then find a null pointer. The library is
    pinned with RTLD_NODELETE so the registered function stays mapped.
    """
    if not sys.platform.startswith("linux"):
        return
    try:
        with open("/proc/self/maps") as maps:
            fields = [line.rstrip("\n").split(None, 5) for line in maps]
        new = {f[5] for f in fields if len(f) == 6 and f[5].endswith(".so")
               and any(folder in f[5] for folder in _FMU_LIBRARIES)}
        new -= _GUARDED_LIBRARIES
        if not new:
            return
        cxa_atexit = ctypes.CDLL(None).__cxa_atexit
        cxa_atexit.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]
        cxa_atexit.restype = ctypes.c_int
        for path in sorted(new):
            _GUARDED_LIBRARIES.add(path)
            try:
                lib = ctypes.CDLL(path, mode=os.RTLD_NOLOAD | os.RTLD_NODELETE | os.RTLD_NOW)
                finalize = ctypes.cast(lib.finalizePythonInterpreter, ctypes.c_void_p).value
            except (OSError, AttributeError):
                continue  # not a PythonFMU library after all
            cxa_atexit(finalize, None, None)
    except Exception:  # never fail an instantiation over this
        return
