"""The kernels' cache (iceimpact/compiled.py): in the user's cache folder, never beside the
source; found again by an identical source at a new path (a fresh FMU extraction); a damaged
or unusable cache compiles again; the results those of the pure path, to the bit."""

from __future__ import annotations

import json
import os
import shutil
import stat
import subprocess
import sys
import types
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from iceimpact import compiled

SRC = Path(__file__).resolve().parents[1] / "fmu_src" / "iceimpact"

#: a fresh process: imports the core from the folder on its PYTHONPATH, runs a linear and a
#: quadratic (sticking: the Taylor kernels) scene, reports numba's cache hits and misses and the
#: results' digest
_PROBE = """
import hashlib, json, sys
import numpy as np
import iceimpact
from iceimpact import Scene, run
from iceimpact import compiled
h = hashlib.sha256()
for fields, t_end in (({}, 30.0), ({"drag_model": 2, "impact_e": 0.5}, 20.0)):
    r = run(Scene(**fields), t_end, dt=1e-2)
    for key in ("t", "x", "v", "z", "w", "impulse", "sticking"):
        h.update(np.ascontiguousarray(getattr(r, key)).tobytes())
    h.update(np.ascontiguousarray(r.impacts["t"]).tobytes())
print(json.dumps({"file": iceimpact.__file__, "digest": h.hexdigest(), **compiled.cache_stats()}))
"""


def _probe(source_parent: Path, cache: Path | str | None, pure: bool = False) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith("ICEIMPACT_")}
    env["PYTHONDONTWRITEBYTECODE"] = "1"  # nothing but numba could write beside the source
    env["ICEIMPACT_PURE"] = "1" if pure else "0"
    if cache is not None:
        env["ICEIMPACT_CACHE_DIR"] = str(cache)
    env["PYTHONPATH"] = str(source_parent)  # the copy, ahead of the installed core
    done = subprocess.run([sys.executable, "-W", "error::RuntimeWarning", "-c", _PROBE],
                          env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    seen = json.loads(done.stdout.strip().splitlines()[-1])
    assert seen["file"].startswith(str(source_parent))  # the copy ran, not the installed core
    return seen


def _read_only_copy(target: Path) -> Path:
    """The core copied under ``target``, its folders and files read-only; ``target``."""
    shutil.copytree(SRC, target / "iceimpact",
                    ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    for folder, _, files in os.walk(target / "iceimpact"):
        for name in files:
            os.chmod(os.path.join(folder, name), 0o444)
        os.chmod(folder, 0o555)
    return target


def _writable(target: Path) -> None:
    for folder, _, _ in os.walk(target):
        os.chmod(folder, 0o755)


def _numba_files(folder: Path) -> list[Path]:
    return [p for p in folder.rglob("*") if p.suffix in (".nbi", ".nbc")]


@pytest.fixture(scope="module")
def warm(tmp_path_factory):
    """A cache filled by a first process (all kernels compiled), the source it compiled, and
    the pure path's digest."""
    pytest.importorskip("numba")
    tmp = tmp_path_factory.mktemp("compiled_cache")
    source = _read_only_copy(tmp / "first")
    first = _probe(source, tmp / "cache")
    pure = _probe(source, tmp / "unused", pure=True)
    yield {"source": source, "cache": tmp / "cache", "first": first, "pure": pure["digest"]}
    _writable(tmp)


def test_a_read_only_source_caches_in_the_users_folder(warm):
    """The first process compiles every kernel and writes their entries under
    ICEIMPACT_CACHE_DIR, none beside the (read-only) source; its results are the pure path's."""
    first = warm["first"]
    assert first["kernels"] >= 9 and first["misses"] == first["kernels"]
    assert first["hits"] == 0
    assert all(f is not None and Path(f).parent == warm["cache"] for f in first["folders"])
    assert len({Path(f).name for f in first["folders"]}) == first["kernels"]
    assert not _numba_files(warm["source"])
    assert _numba_files(warm["cache"])
    assert first["digest"] == warm["pure"]


def test_an_identical_source_at_a_new_path_loads_from_the_cache(warm, tmp_path):
    """A fresh process whose core is a new copy of the same source (as a freshly extracted FMU
    is) loads every kernel from the cache: no compilation, the same results."""
    source = _read_only_copy(tmp_path / "elsewhere")
    try:
        again = _probe(source, warm["cache"])
    finally:
        _writable(tmp_path)
    assert again["hits"] == again["kernels"] == warm["first"]["kernels"]
    assert again["misses"] == 0
    assert again["folders"] == warm["first"]["folders"]
    assert again["digest"] == warm["pure"]


def test_a_changed_source_compiles_again(warm, tmp_path):
    """A kernel's module whose content changed (a comment added) misses the entries of the old
    one: its kernels compile, the other module's load."""
    source = tmp_path / "changed"
    shutil.copytree(warm["source"], source)
    _writable(source)
    taylor = source / "iceimpact" / "solvers" / "search" / "taylor.py"
    os.chmod(taylor, 0o644)
    taylor.write_text(taylor.read_text() + "\n# changed\n")
    seen = _probe(source, warm["cache"])
    changed = [f for f in seen["folders"] if Path(f).name.startswith("taylor.")]
    assert changed and seen["misses"] == len(changed)
    assert seen["hits"] == seen["kernels"] - len(changed)
    assert seen["digest"] == warm["pure"]


def test_a_damaged_cache_compiles_again_and_is_mended(warm, tmp_path):
    """Data files cut short or with a byte changed, an index of garbage: those kernels compile
    again (no crash, no warning, the same results) and their entries are rewritten, so the
    next process loads every kernel."""
    cache = tmp_path / "cache"
    shutil.copytree(warm["cache"], cache)
    folders = sorted(cache.iterdir())
    cut, flipped, garbage = folders[0], folders[1], folders[2]
    data = next(cut.glob("*.nbc"))
    data.write_bytes(data.read_bytes()[:len(data.read_bytes()) // 2])
    data = next(flipped.glob("*.nbc"))
    blob = bytearray(data.read_bytes())
    blob[len(blob) // 2] ^= 0x01
    data.write_bytes(bytes(blob))
    next(garbage.glob("*.nbi")).write_bytes(b"not an index")
    mended = _probe(warm["source"], cache)
    assert mended["misses"] == 3 and mended["hits"] == mended["kernels"] - 3
    assert mended["digest"] == warm["pure"]
    after = _probe(warm["source"], cache)
    assert after["hits"] == after["kernels"] and after["misses"] == 0


def test_an_unusable_cache_folder_compiles_without_a_cache(warm, tmp_path):
    """ICEIMPACT_CACHE_DIR a file, or a folder other users may write (its entries could be
    anyone's): nothing is cached or read there; every kernel compiles, the same results (both
    processes side by side: each compiles every kernel)."""
    a_file, shared = tmp_path / "a file", tmp_path / "writable by others"
    a_file.write_text("")
    shutil.copytree(warm["cache"], shared)
    os.chmod(shared, 0o777)
    with ThreadPoolExecutor(2) as pool:
        reports = list(pool.map(lambda cache: _probe(warm["source"], cache), (a_file, shared)))
    for seen in reports:
        assert seen["folders"] == [None] * seen["kernels"]
        assert seen["misses"] == seen["kernels"] and seen["hits"] == 0
        assert seen["digest"] == warm["pure"]


# -- the parts, in this process ----------------------------------------------------------------

_NUMBA = types.SimpleNamespace(__version__="0.0")
LIMIT = 1.5


def _kernel(x):
    return min(x, LIMIT)


def test_the_key_follows_the_globals_a_kernel_reads(monkeypatch):
    """A constant the kernel reads (numba freezes it into the machine code) changes its key, as
    does the signature; a global it does not read does not; an object with no stable
    description leaves the kernel uncached (no key)."""
    key = compiled.cache_key(_NUMBA, _kernel, "f8(f8)")
    assert key == compiled.cache_key(_NUMBA, _kernel, "f8(f8)")
    assert key != compiled.cache_key(_NUMBA, _kernel, "f4(f4)")
    monkeypatch.setattr(sys.modules[__name__], "LIMIT", 1.5000000000000002)
    assert compiled.cache_key(_NUMBA, _kernel, "f8(f8)") != key
    monkeypatch.setattr(sys.modules[__name__], "LIMIT", 1.5)
    monkeypatch.setattr(sys.modules[__name__], "_UNREAD", 3, raising=False)
    assert compiled.cache_key(_NUMBA, _kernel, "f8(f8)") == key
    monkeypatch.setattr(sys.modules[__name__], "LIMIT", object())
    assert compiled.cache_key(_NUMBA, _kernel, "f8(f8)") is None


def test_the_cache_root_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.setenv("ICEIMPACT_CACHE_DIR", str(tmp_path / "here"))
    assert compiled.cache_root() == str(tmp_path / "here")
    monkeypatch.delenv("ICEIMPACT_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert compiled.cache_root() == str(tmp_path / "xdg" / "iceimpact" / "numba")
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert compiled.cache_root() == str(tmp_path / "home" / ".cache" / "iceimpact" / "numba")


@pytest.mark.skipif(os.name == "nt", reason="POSIX permissions")
def test_only_a_private_folder_is_used(tmp_path):
    made = tmp_path / "a" / "b"
    assert compiled.private_folder(str(made))
    assert stat.S_IMODE(made.stat().st_mode) == 0o700
    os.chmod(made, 0o770)
    assert not compiled.private_folder(str(made))
    (tmp_path / "file").write_text("")
    assert not compiled.private_folder(str(tmp_path / "file"))


def test_a_sealed_file_read_back_or_refused(tmp_path):
    path = str(tmp_path / "entry")
    compiled._seal(path, b"\x80\x04K\x07.")  # pickle of 7
    assert compiled._unsealed(path) == 7
    blob = bytearray(Path(path).read_bytes())
    blob[-2] ^= 0x01
    Path(path).write_bytes(bytes(blob))
    with pytest.raises(ValueError):
        compiled._unsealed(path)
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".tmp-")]


def test_older_entries_of_a_kernel_are_pruned(tmp_path):
    """Each edit of a kernel's source makes a new entry: the newest ``keep`` stay, the other
    kernels' entries are not touched."""
    for i in range(10):
        for name in ("mod.kernel", "mod.kernel_two"):
            folder = tmp_path / f"{name}-{i:024d}"
            folder.mkdir()
            os.utime(folder, (1000.0 + i, 1000.0 + i))
    compiled._prune(str(tmp_path), "mod.kernel-", keep=8)
    left = sorted(p.name for p in tmp_path.iterdir() if p.name.startswith("mod.kernel-"))
    assert left == [f"mod.kernel-{i:024d}" for i in range(2, 10)]
    assert len([p for p in tmp_path.iterdir() if p.name.startswith("mod.kernel_two-")]) == 10


def test_every_kernel_compiles_where_numba_is():
    """Where numba is installed (and ICEIMPACT_PURE unset) every module's kernels compile: a
    kernel numba refuses falls back to the pure path with only a warning, and its tests of
    compiled against pure would be skipped, not failed."""
    from iceimpact.compiled import numba_or_none
    if numba_or_none() is None:
        pytest.skip("numba is not installed (or ICEIMPACT_PURE is set): nothing compiled")
    from iceimpact.physics import elementwise
    from iceimpact.solvers.exact import bounces
    from iceimpact.solvers.search import flight_search, modal_search, modal_taylor, taylor
    from iceimpact.studies import loads
    compiled = {"bounces": bounces.COMPILED, "flight_search": flight_search.COMPILED,
                "taylor": taylor.KERNELS, "elementwise": elementwise._COMPILED,
                "loads": loads._COUNT, "bounces under the quadratic Morison drag":
                bounces.dragged_kernel(), "modal_search": modal_search.COMPILED,
                "bounces on the modes": bounces.modal_kernel(),
                "modal_taylor": modal_taylor.COMPILED}
    assert [name for name, kernel in compiled.items() if kernel is None] == []


def _row_sum(arrays, j):
    """A kernel that unpacks a tuple of arrays and views a row: each takes a reference where
    numba's runtime counts them."""
    first, second = arrays[0], arrays[1]
    row = first[j]
    return row[0] + second[j, 1]


def _makes_an_array(n):
    return np.zeros(n)[0]


def test_a_borrowing_kernel_counts_no_references_and_may_make_no_array():
    """``borrows``: compiled without numba's runtime, the same result as the counting kernel,
    cached under another key; a function that makes an array is refused, so a borrowing kernel
    never owns one. The modal structure's search and march borrow (their tuple of arrays would
    otherwise cost atomic counts at every point of the search)."""
    from iceimpact.compiled import numba_or_none
    numba = numba_or_none()
    if numba is None:
        pytest.skip("numba is not installed (or ICEIMPACT_PURE is set): nothing compiled")
    a2 = numba.float64[:, ::1]
    signature = (numba.types.Tuple((a2, a2)), numba.int64)
    arrays = (np.arange(6.0).reshape(3, 2), np.arange(6.0, 12.0).reshape(3, 2))
    borrowing = compiled.jit(numba, signature, _row_sum, borrows=True)
    counting = compiled.jit(numba, signature, _row_sum)
    assert borrowing(arrays, 2) == counting(arrays, 2) == _row_sum(arrays, 2) == 4.0 + 11.0
    assert borrowing.targetoptions["_nrt"] is False
    assert counting.targetoptions.get("_nrt", True) is not False
    assert (compiled.cache_key(numba, _row_sum, signature, {**compiled._OPTIONS, "_nrt": False})
            != compiled.cache_key(numba, _row_sum, signature))
    with pytest.raises(numba.core.errors.TypingError, match="zeros"):
        compiled.jit(numba, (numba.int64,), _makes_an_array, borrows=True)
    from iceimpact.solvers.exact import bounces
    from iceimpact.solvers.search import modal_search
    if bounces.modal_kernel() is None:
        pytest.skip("the modal march is not compiled")
    for name in ("flight_root", "_mode_increment"):
        assert modal_search._DISPATCHERS[name].targetoptions["_nrt"] is False, name


# -- one source run on other functions: the names given, and the state's fields ---------------

_OTHER = 2.0  # a global of this module that _kernel does not read


def test_a_callee_is_given_only_by_a_name_the_function_reads():
    """rebound (and so jit, before numba sees the function) refuses a name the function does
    not read (a misspelling, a global it does not use) and a name it reads that is not a global
    of its module, each naming the function and the name; a name it reads is given."""
    assert compiled.rebound(_kernel, LIMIT=0.5)(3.0) == 0.5
    for name in ("LIMTI", "_OTHER"):
        with pytest.raises(TypeError, match=f"_kernel does not read the name '{name}'"):
            compiled.rebound(_kernel, **{name: 0.5})
        with pytest.raises(TypeError, match=name):
            compiled.jit(_NUMBA, "f8(f8)", _kernel, **{name: 0.5})
    with pytest.raises(TypeError, match="'min' is not a global of .*_kernel reads it"):
        compiled.rebound(_kernel, min=max)
    assert _kernel(3.0) == LIMIT  # the module's function keeps its own


_TABLE = compiled.fields("Table", "FIRST", "SECOND")


def _reads_table(a):
    return a[_TABLE.SECOND]


def test_fields_number_a_table_of_names_and_key_the_kernels_that_read_them(monkeypatch):
    """fields numbers its names 0, 1, ... (its length the array's size); a kernel that reads
    the table has a key that changes when the table's names or order change."""
    assert (_TABLE.FIRST, _TABLE.SECOND, len(_TABLE)) == (0, 1, 2)
    assert _reads_table([5.0, 7.0]) == 7.0
    key = compiled.cache_key(_NUMBA, _reads_table, "f8(f8[::1])")
    assert key is not None
    for other in (compiled.fields("Table", "SECOND", "FIRST"),
                  compiled.fields("Table", "FIRST", "OTHER"),
                  compiled.fields("Table", "FIRST", "SECOND", "THIRD")):
        monkeypatch.setattr(sys.modules[__name__], "_TABLE", other)
        assert compiled.cache_key(_NUMBA, _reads_table, "f8(f8[::1])") != key


def test_the_march_of_bounces_is_given_its_structure_by_the_names_of_one_table(monkeypatch):
    """The march's state arrays are sized and indexed by their tables, every field once; the
    structure's callees under the quadratic Morison drag are exactly those the table names,
    each read by the march; the march's cache key follows its tables."""
    from iceimpact.solvers.exact import bounces

    for table in (bounces.FLOATS, bounces.INTS, bounces.PARAMS):
        assert list(table) == list(range(len(table)))
        assert len(set(table._fields)) == len(table)
    assert set(bounces.DRAGGED_CALLEES) == set(bounces.STRUCTURE_CALLEES)
    read = compiled._names_read(bounces.bounce_march.__code__)
    assert set(bounces.STRUCTURE_CALLEES) <= read
    with pytest.raises(KeyError):
        bounces._structure_callees({**bounces.DRAGGED_CALLEES, "_motion": None})
    key = compiled.cache_key(_NUMBA, bounces.bounce_march, "march")
    assert key is not None
    swapped = compiled.fields("Ints", *reversed(bounces.INTS._fields))
    monkeypatch.setattr(bounces, "INTS", swapped)
    assert compiled.cache_key(_NUMBA, bounces.bounce_march, "march") != key
