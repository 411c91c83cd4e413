"""numba for the kernels of the exact method and the sampler: whether they are compiled, and
how, and where their machine code is cached.

A kernel is a function over plain floats and arrays that runs as Python as it is, and compiled
by numba where numba is installed (the ``fast`` extra) and ``ICEIMPACT_PURE`` is not set in the
environment. numba compiles it without ``fastmath`` (no contraction of a product and a sum into
one fused operation, no reordering), and its ``math`` functions call the same C library as
CPython's, so the compiled kernel gives the same floats as the pure one.

**The cache.** Compiling every kernel takes seconds, so numba's machine code for each kernel is
kept in a per-user folder, :func:`cache_root`: ``$ICEIMPACT_CACHE_DIR``, else
``$XDG_CACHE_HOME/iceimpact/numba`` (``~/.cache/iceimpact/numba``; ``%LOCALAPPDATA%`` on
Windows), never beside the source, which may be read-only (a site-packages install) or new at
every run (an FMU extracted afresh). A kernel's entry there is found by what it was compiled
from, not by where the source lies: a digest (:func:`cache_key`) of numba's and Python's versions,
the module's name, the source file's content, the kernel's compile options and signature, the
values of the globals it reads (constants numba freezes into the machine code, imported from
other modules too) and the digests of the kernels it calls. An identical source at a new path
finds it; any change of these compiles again (the newest ``_KEEP`` entries of each kernel are
kept, the older ones removed). Within that entry numba's own index keys the code
by signature, CPU and bytecode.

The entries are numba's own (the same pickles ``cache=True`` writes), each file sealed with a
SHA-256 of its bytes, and read only from a folder the user owns that no one else can write
(:func:`private_folder`): a damaged file (cut short, changed) is a miss, which compiles and
overwrites it; a folder that cannot be made, is not private or cannot be written leaves the
kernel compiled at each import, uncached. Deleting the folder is always safe.
"""

from __future__ import annotations

import collections
import hashlib
import os
import pickle
import shutil
import sys
import tempfile
import types
import warnings
from collections.abc import Callable
from typing import Any

#: the digest a kernel's copy and its dispatcher carry (:func:`cache_key`)
_KEY = "_iceimpact_cache_key"
#: the first bytes of every cache file written here: a changed layout never reads an old one
_HEADER = b"iceimpact numba cache 1\n"
#: the compile options of every kernel (no fastmath: the pure path's floats; see the docstring)
_OPTIONS = {"fastmath": False, "error_model": "python"}
#: entries kept per kernel (the newest): sources edited, other versions of the package
_KEEP = 8
#: the dispatchers :func:`jit` made in this process, for :func:`cache_stats`
_DISPATCHERS: list[Any] = []


def numba_or_none() -> Any:
    """The numba module, or None where it is not installed, ``ICEIMPACT_PURE`` is set, or numba
    would vectorise loops of math calls with Intel's SVML (other roundings than the C
    library's: the kernels' loops over samples would no longer give the pure path's floats)."""
    if os.environ.get("ICEIMPACT_PURE", "") not in ("", "0"):
        return None
    try:
        import numba
    except ImportError:
        return None
    if getattr(numba.config, "USING_SVML", False):
        return None
    return numba


def rebound(function: Callable, **callees: Any) -> Callable:
    """A copy of ``function`` whose calls of the names in ``callees`` call those instead (its
    module's names keep theirs): one source run on other functions, as :func:`jit` compiles
    it.

    Each name must be a global of ``function``'s module that its code reads (TypeError
    otherwise, naming both): a misspelt or unused name would leave the module's function in
    place, silently."""
    read = _names_read(function.__code__)
    for name in callees:
        if name not in read:
            raise TypeError(f"{function.__qualname__} does not read the name {name!r}: "
                            "it cannot be given in its place")
        if name not in function.__globals__:
            raise TypeError(f"{name!r} is not a global of {function.__module__}, where "
                            f"{function.__qualname__} reads it: nothing to give in its place")
    copy = types.FunctionType(function.__code__, {**function.__globals__, **callees},
                              function.__name__)
    copy.__qualname__ = function.__qualname__
    return copy


def fields(typename: str, *names: str) -> Any:
    """The fields of a kernel's state array, numbered 0, 1, ... in the order of ``names``: a
    named tuple of ints (``fields("State", "T", "X").X == 1``), its length the array's size.

    A kernel indexes the array by them (``F[FLOATS.T0]``): numba freezes a global tuple as a
    constant and folds the attribute, the same machine code as a literal index; the tuple's
    names and numbers are in the kernel's cache key (:func:`cache_key`)."""
    return collections.namedtuple(typename, names)(*range(len(names)))


def jit(numba: Any, signature: Any, function: Callable, *, borrows: bool = False,
        **callees: Any) -> Any:
    """``function`` compiled for its one signature (at once, its machine code cached in
    :func:`cache_root` for later imports), the functions it calls by the names in ``callees``
    replaced by their compiled forms (the module's names keep the pure ones).

    ``borrows``: compiled without numba's runtime (its reference counts): the function makes no
    array and only reads and writes the arrays it is handed, which its caller keeps alive. Each
    array a call, a tuple or a view takes otherwise costs two atomic operations; in a kernel
    that hands a tuple of arrays to its functions at every point, they are most of its time."""
    copy = rebound(function, **callees)
    options = {**_OPTIONS, "_nrt": False} if borrows else _OPTIONS
    key = cache_key(numba, copy, signature, options)
    setattr(copy, _KEY, key)
    dispatcher = numba.njit(**options)(copy)
    if key is not None:
        _cache_in_folder(numba, dispatcher, copy)
    from numba.core import typeinfer

    # as numba.njit(signature) compiles: registered, so that the kernel may call itself
    with typeinfer.register_dispatcher(dispatcher):
        dispatcher.compile(signature)
    dispatcher.disable_compile()
    setattr(dispatcher, _KEY, key)
    _DISPATCHERS.append(dispatcher)
    return dispatcher


def entry_point(dispatcher: Any) -> Callable:
    """The compiled function of a one-signature dispatcher, called without the dispatcher's
    matching of argument types (the caller passes the signature's types)."""
    return dispatcher.overloads[dispatcher.signatures[0]].entry_point


def not_compiled(what: str, exc: Exception) -> None:
    """Say that numba failed on ``what``: the pure path runs."""
    warnings.warn(f"numba could not compile {what} ({exc}); the pure path runs (the same "
                  "results, slower)", RuntimeWarning, stacklevel=3)


def compile_or_none(what: str, build: Callable[[Any], Any]) -> Any:
    """``build(numba)``: the compiled kernels of a module, or None where numba is not installed,
    ``ICEIMPACT_PURE`` is set, or numba fails on them (said once, :func:`not_compiled`): the
    pure path runs."""
    numba = numba_or_none()
    if numba is None:
        return None
    try:
        return build(numba)
    except Exception as exc:  # (any failure of numba leaves the pure path)
        not_compiled(what, exc)
        return None


def cache_stats() -> dict[str, Any]:
    """The kernels compiled in this process: how many numba loaded from the cache (hits), how
    many it compiled (misses), and the folders of their entries (None: not cached)."""
    hits = misses = 0
    folders = []
    for dispatcher in _DISPATCHERS:
        stats = dispatcher.stats
        hits += sum(stats.cache_hits.values())
        misses += sum(stats.cache_misses.values())
        ours = isinstance(dispatcher._cache, tuple(_classes.values()))
        folders.append(dispatcher._cache.cache_path if ours else None)
    return {"kernels": len(_DISPATCHERS), "hits": hits, "misses": misses, "folders": folders}


# -- where the cache lives -------------------------------------------------------------------

def cache_root() -> str:
    """The folder of the kernels' cache: ``$ICEIMPACT_CACHE_DIR``, else the user's cache folder
    (``$XDG_CACHE_HOME``, ``~/.cache``; ``%LOCALAPPDATA%`` on Windows) + ``iceimpact/numba``."""
    explicit = os.environ.get("ICEIMPACT_CACHE_DIR", "")
    if explicit:
        return os.path.abspath(explicit)
    if os.name == "nt" and os.environ.get("LOCALAPPDATA"):
        base = os.environ["LOCALAPPDATA"]
    else:
        base = os.environ.get("XDG_CACHE_HOME", "") or os.path.join(os.path.expanduser("~"),
                                                                     ".cache")
    return os.path.join(os.path.abspath(base), "iceimpact", "numba")


def private_folder(path: str) -> bool:
    """Make ``path`` (mode 0700) if it is missing; whether it is a folder this user owns that
    no other user can write (on POSIX; anything a folder on Windows), so that no one else's
    bytes are ever loaded as machine code."""
    try:
        os.makedirs(path, mode=0o700, exist_ok=True)
        status = os.stat(path)
    except OSError:
        return False
    if not os.path.isdir(path):
        return False
    if os.name == "nt":
        return True
    return status.st_uid == os.geteuid() and not status.st_mode & 0o022


def cache_key(numba: Any, function: Callable, signature: Any,
              options: dict[str, Any] | None = None) -> str | None:
    """The digest that names ``function``'s cache entry (the module docstring says of what), or
    None where one of its parts cannot be read (its source file, a global with no stable
    description): that kernel is then not cached. ``options``: its compile options (default
    every kernel's, ``_OPTIONS``)."""
    try:
        with open(function.__code__.co_filename, "rb") as fh:
            source = hashlib.sha256(fh.read()).hexdigest()
        parts = [f"numba {numba.__version__}", f"python {sys.version}", sys.platform,
                 f"module {function.__module__}", f"source {source}",
                 f"options {options or _OPTIONS}",
                 f"signature {signature}", f"qualname {function.__qualname__}"]
        for name in sorted(_names_read(function.__code__)):
            if name in function.__globals__:
                parts.append(f"{name} = {_describe(function.__globals__[name])}")
    except (OSError, _Unkeyable):
        return None
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()


class _Unkeyable(Exception):
    """A global whose value has no description that is the same in every process."""


def _names_read(code: types.CodeType) -> set[str]:
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            names |= _names_read(const)
    return names


def _describe(value: Any) -> str:
    """A description of a global that is the same in every process and changes with what numba
    would freeze of it."""
    if value is None or isinstance(value, (bool, int, str, bytes)):
        return f"{type(value).__name__} {value!r}"
    if isinstance(value, float):
        return f"float {value.hex()}"
    if isinstance(value, complex):
        return f"complex {value.real.hex()} {value.imag.hex()}"
    if isinstance(value, (tuple, list)):
        names = getattr(type(value), "_fields", ())  # a named tuple's (:func:`fields`)
        return (f"{type(value).__name__}{names or ''} "
                f"({', '.join(map(_describe, value))})")
    if isinstance(value, types.ModuleType):
        return f"module {value.__name__}"
    key = getattr(value, _KEY, False)
    if key is not False:  # a kernel compiled here: its own digest
        if key is None:
            raise _Unkeyable(value)
        return f"kernel {key}"
    if hasattr(value, "dtype") and hasattr(value, "tobytes"):  # a numpy array or scalar
        return (f"array {value.dtype.str} {getattr(value, 'shape', ())} "
                f"{hashlib.sha256(value.tobytes()).hexdigest()}")
    if isinstance(value, (types.BuiltinFunctionType, types.FunctionType, type)):
        return f"callable {value.__module__}.{value.__qualname__}"
    raise _Unkeyable(value)


def _cache_in_folder(numba: Any, dispatcher: Any, function: Callable) -> None:
    """Give ``dispatcher`` its cache in :func:`cache_root`, or none (compiled at each import)
    where that folder is not usable."""
    try:
        dispatcher._cache = _cache_class(numba)(function)
    except Exception:  # no private folder to write: numba's default NullCache stays
        pass


# -- numba's cache, located by content and sealed ---------------------------------------------

_classes: dict[int, type] = {}


def _cache_class(numba: Any) -> type:
    """numba's FunctionCache with the locator and the sealed files of this module (made once,
    so that numba is imported only where it is used)."""
    if id(numba) in _classes:
        return _classes[id(numba)]
    from numba.core.caching import CompileResultCacheImpl, FunctionCache, _CacheLocator
    from numba.core.serialize import dumps

    class Locator(_CacheLocator):
        """The entry of one kernel: ``<cache_root>/<file>.<qualname>-<digest>``."""

        def __init__(self, py_func: Callable, folder: str, key: str):
            self._py_file = py_func.__code__.co_filename
            self._lineno = py_func.__code__.co_firstlineno
            self._folder = folder
            self._key = key

        def get_cache_path(self) -> str:
            return self._folder

        def ensure_cache_path(self) -> None:
            if not (private_folder(os.path.dirname(self._folder))
                    and private_folder(self._folder)):
                raise OSError(f"{self._folder} is not a private folder of this user")
            tempfile.TemporaryFile(dir=self._folder).close()  # writable

        def get_source_stamp(self) -> str:
            return self._key  # the source's content is in it (numba's own stamp is too)

        def get_disambiguator(self) -> str:
            return str(self._lineno)

        @classmethod
        def from_function(cls, py_func: Callable, py_file: str) -> Any:
            key = getattr(py_func, _KEY, None)
            if key is None:
                return None
            stem = os.path.splitext(os.path.basename(py_file))[0]
            name = f"{stem}.{py_func.__qualname__}".replace("<", "").replace(">", "")
            self = cls(py_func, os.path.join(cache_root(), f"{name}-{key[:24]}"), key)
            new = not os.path.isdir(self._folder)
            try:
                self.ensure_cache_path()
            except OSError:
                return None
            if new:
                _prune(cache_root(), f"{name}-", keep=_KEEP)
            return self

    class Impl(CompileResultCacheImpl):
        _locator_classes = [Locator]

    class SealedFiles:
        """numba's index (signature, CPU, bytecode -> data file) and data files, each written
        whole (a temporary file renamed) with the seal and a SHA-256 of its bytes in front,
        which are checked before anything is unpickled."""

        def __init__(self, folder: str, base: str, stamp: str):
            self._folder = folder
            self._index_path = os.path.join(folder, f"{base}.nbi")
            self._data_pattern = f"{base}.{{}}.nbc"
            self._stamp = (numba.__version__, stamp)

        def load(self, key: Any) -> Any:
            name = self._index().get(key)
            if name is None:
                return None
            return _unsealed(os.path.join(self._folder, name))

        def save(self, key: Any, data: Any) -> None:
            overloads = self._index()
            name = overloads.get(key)
            if name is None:
                used = set(overloads.values())
                name = next(n for n in map(self._data_pattern.format, range(1, len(used) + 2))
                            if n not in used)
                overloads[key] = name
            _seal(os.path.join(self._folder, name), dumps(data))
            _seal(self._index_path, dumps((self._stamp, overloads)))

        def flush(self) -> None:
            _seal(self._index_path, dumps((self._stamp, {})))

        def _index(self) -> dict:
            try:
                stamp, overloads = _unsealed(self._index_path)
            except FileNotFoundError:
                return {}
            except Exception:  # damaged: its entries compile again and rewrite it
                return {}
            return overloads if stamp == self._stamp and isinstance(overloads, dict) else {}

    class Cache(FunctionCache):
        """numba's per-function cache in :func:`cache_root`; a load that fails in any way is a
        miss (the kernel compiles), a save that fails leaves the compiled kernel uncached."""

        _impl_class = Impl

        def __init__(self, py_func: Callable):
            super().__init__(py_func)
            self._cache_file = SealedFiles(self._cache_path, self._impl.filename_base,
                                           self._impl.locator.get_source_stamp())

        def load_overload(self, sig: Any, target_context: Any) -> Any:
            try:
                return super().load_overload(sig, target_context)
            except Exception:
                return None

        def save_overload(self, sig: Any, data: Any) -> None:
            try:
                super().save_overload(sig, data)
            except Exception:
                pass

    _classes[id(numba)] = Cache
    return Cache


def _prune(root: str, prefix: str, keep: int) -> None:
    """Remove all but the ``keep`` newest entries of one kernel (a process still reading one
    finds its files gone: a miss, which compiles)."""
    try:
        entries = [e for e in os.scandir(root) if e.name.startswith(prefix) and e.is_dir()]
        entries.sort(key=lambda e: e.stat().st_mtime, reverse=True)
        for entry in entries[keep:]:
            shutil.rmtree(entry.path, ignore_errors=True)
    except OSError:
        pass


def _seal(path: str, payload: bytes) -> None:
    """Write ``path`` whole: seal, SHA-256 of ``payload``, ``payload`` (a temporary file
    renamed over it, so that a reader in another process sees the old file or the new one)."""
    folder = os.path.dirname(path)
    fd, temporary = tempfile.mkstemp(dir=folder, prefix=".tmp-")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(_HEADER + hashlib.sha256(payload).digest() + payload)
        os.replace(temporary, path)
    except BaseException:
        try:
            os.unlink(temporary)
        except OSError:
            pass
        raise


def _unsealed(path: str) -> Any:
    """What :func:`_seal` wrote at ``path``; ValueError if the file is not whole and unchanged."""
    with open(path, "rb") as fh:
        blob = fh.read()
    head = len(_HEADER)
    digest, payload = blob[head:head + 32], blob[head + 32:]
    if not blob.startswith(_HEADER) or hashlib.sha256(payload).digest() != digest:
        raise ValueError(f"{path} is damaged")
    return pickle.loads(payload)  # numba's own pickle, written by _seal in a private folder
