"""The same answer on every machine: the reference runs of methods 1 and 2 (and the external
and the modal structures) under each BLAS kernel and numpy SIMD level this CPU can run, in fresh
processes.

Each configuration sets ``OPENBLAS_CORETYPE`` (the kernel numpy's bundled OpenBLAS uses: Haswell,
SkylakeX, Prescott) and, or not, ``NPY_DISABLE_CPU_FEATURES`` (numpy's AVX-512 loops off, as on a
CPU without AVX-512). Its process reports the kernel and the SIMD target it really got, the digests
of every number of the reference runs (tests/reference_digests.py: states, impulses, impact lists,
``run()``'s samples) and of the outputs of IceImpact.fmu simulated by FMPy. Every configuration must
give the stored digests: the core's event arithmetic makes no BLAS call and uses no numpy function
whose bits depend on the SIMD level (docs/explanation/accuracy.md#machine-independence). Method 3
integrates with scipy, which uses BLAS: its runs are compared within its error bound
(tests/solvers/test_ode.py), never by digests.

One more configuration is the C library's: glibc picks its ``exp``, ``sin``, ``cos``... by CPU as
well, an FMA variant where the CPU has FMA and AVX2, an SSE2 one where not (x86-64 CPUs before 2013,
and low-power ones since), and the two differ in the last bit for about 1 argument in 1,000.
``GLIBC_TUNABLES=glibc.cpu.hwcaps=-AVX2,-FMA`` gives a process the SSE2 variants: there the events
of the reference runs (every impact's time, velocities and impulse, the sticking flags) are the
stored ones, while states between impacts may differ in their last bits (measured, and what
``reference_digests.event_quantities`` names; docs/explanation/accuracy.md#machine-independence).
"""

from __future__ import annotations

import functools
import json
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

import random_scenes
import reference_digests
from fmu_host import ROOT

KERNELS = ("Haswell", "SkylakeX", "Prescott")
#: The CPU flags (/proc/cpuinfo) a kernel needs.
KERNEL_NEEDS = {"Haswell": ("avx2", "fma"), "SkylakeX": ("avx512f", "avx512bw", "avx512vl"),
                "Prescott": ("pni",)}  # (SSE3, as /proc/cpuinfo names it)
LIBM_SSE2 = "C library without FMA"
CONFIGS = [(kernel, simd) for kernel in KERNELS for simd in ("all SIMD", "no AVX-512")]
CONFIGS.append(("Haswell", LIBM_SSE2))
#: An argument whose exp the C library's FMA and SSE2 variants round differently (glibc 2.36):
#: a process reports its exp, which tells which variant it runs.
LIBM_PROBE = float.fromhex("-0x1.36c379d59ee98p+2")

#: The FMU runs of each configuration: (scene changes, stop time s, step s).
FMU_RUNS = ({"impact.e": 0.5}, {"drag.model": 2, "impact.e": 0.5},
            {"solver.method": 2, "drag.model": 2},
            {"structure.model": 3, "structure.modes": 2, "structure.mode2.f": 11.0,
             "structure.mode2.zeta": 0.02, "structure.mode2.phi": 0.6, "drag.model": 2,
             "flow.u": 0.3, "ice.M": 1200.0, "impact.e": 0.7})

_WORKER = r"""
import ctypes, glob, hashlib, json, os, sys
import numpy as np
from numpy.lib.introspect import opt_func_info
import random_scenes
import reference_digests

def blas_kernel():
    here = os.path.dirname(np.__file__)
    for lib in glob.glob(os.path.join(here, os.pardir, "numpy.libs", "*openblas*.so*")):
        cdll = ctypes.CDLL(lib)
        for name in ("scipy_openblas_get_corename64_", "scipy_openblas_get_corename",
                     "openblas_get_corename64_", "openblas_get_corename"):
            if hasattr(cdll, name):
                function = getattr(cdll, name)
                function.restype = ctypes.c_char_p
                return function().decode()
    return "unknown"

names = json.loads(sys.argv[1])
import math
out = {"kernel": blas_kernel(), "libm_probe": math.exp(float.fromhex(sys.argv[4])).hex(),
       "exp_target": opt_func_info(func_name="^exp$", signature="float64")["exp"]["dd"]["current"],
       "digests": reference_digests.compute(names), "fmu": {}}
out["random"] = random_scenes.digest(random_scenes.from_json(sys.argv[5]), compiled=True)
fmu = sys.argv[2]
if fmu:
    from fmpy import simulate_fmu
    for i, changes in enumerate(json.loads(sys.argv[3])):
        result = simulate_fmu(fmu, stop_time=5.0, step_size=1e-2, output_interval=1e-2,
                              start_values=changes)
        digest = hashlib.sha256(np.ascontiguousarray(
            np.column_stack([result[name] for name in result.dtype.names])).tobytes())
        out["fmu"][str(i)] = digest.hexdigest()
print(json.dumps(out))
"""


#: Random scenes (tests/random_scenes.py, tools/random_search.py's strategy) each configuration
#: runs with the compiled march of bounces, and the seed of their draw (drawn here, handed to
#: each configuration's process as JSON).
RANDOM_SCENES, RANDOM_SEED = 30, 7


def cpu_flags() -> set[str]:
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return set()
    line = next((line for line in text.splitlines() if line.startswith("flags")), "")
    return set(line.partition(":")[2].split())


def avx512_features() -> str:
    """numpy's names of its AVX-512 targets, to disable together (whatever this process itself
    runs: the names, not their state here)."""
    from numpy._core._multiarray_umath import __cpu_features__ as features
    if "X86_V4" in features:  # numpy 2.3 and later
        return "X86_V4 AVX512_ICL AVX512_SPR"
    return "AVX512F AVX512CD AVX512_SKX AVX512_CLX AVX512_CNL AVX512_ICL AVX512_SPR"


def avx512_target(target: str) -> bool:
    """Whether numpy's dispatch target (opt_func_info's "current") is an AVX-512 one."""
    return target == "X86_V4" or target.startswith("AVX512")


def glibc() -> bool:
    try:
        return os.confstr("CS_GNU_LIBC_VERSION") is not None
    except (ValueError, OSError):
        return False


def exact_cases() -> list[str]:
    """The reference runs that must hold on every machine: all but method 3's."""
    return [case[0] for case in reference_digests.CASES]


def skip_reason(kernel: str, simd: str) -> str | None:
    flags = cpu_flags()
    missing = [flag for flag in KERNEL_NEEDS[kernel] if flag not in flags]
    if missing:
        return f"this CPU cannot run OpenBLAS's {kernel} kernel: no {', '.join(missing)} in " \
               "/proc/cpuinfo"
    if simd == "no AVX-512" and "avx512f" not in flags:
        return "this CPU has no AVX-512: the configuration with it is the one without"
    if simd == LIBM_SSE2:
        if not glibc():
            return "not the GNU C library: GLIBC_TUNABLES does not apply"
        if not {"fma", "avx2"} <= flags:
            return "this CPU has no FMA: its C library runs the SSE2 variants everywhere"
    return None


def environment(kernel: str, simd: str) -> dict[str, str]:
    env = {**os.environ, "OPENBLAS_CORETYPE": kernel}
    env.pop("NPY_DISABLE_CPU_FEATURES", None)
    env.pop("GLIBC_TUNABLES", None)
    if simd == "no AVX-512":
        env["NPY_DISABLE_CPU_FEATURES"] = avx512_features()
    if simd == LIBM_SSE2:
        env["GLIBC_TUNABLES"] = "glibc.cpu.hwcaps=-AVX2,-FMA,-AVX512F"
    return env


@functools.cache
def random_cases() -> list[tuple]:
    return random_scenes.draw(RANDOM_SCENES, RANDOM_SEED)


@pytest.fixture(scope="module")
def machine_runs(fmu) -> dict[tuple[str, str], dict]:
    """Each configuration's report (or its skip reason), two processes at a time."""
    def one(config):
        reason = skip_reason(*config)
        if reason:
            return config, reason
        # the worker imports the tests' helpers and tools/ by name
        helpers = [str(ROOT / "tests"), str(ROOT / "tools"),
                   *filter(None, [os.environ.get("PYTHONPATH")])]
        done = subprocess.run([sys.executable, "-c", _WORKER, json.dumps(exact_cases()),
                               str(fmu), json.dumps(FMU_RUNS), LIBM_PROBE.hex(),
                               random_scenes.to_json(random_cases())],
                              env={**environment(*config),
                                   "PYTHONPATH": os.pathsep.join(helpers)},
                              capture_output=True, text=True, timeout=600, cwd=ROOT)
        assert done.returncode == 0, f"{config}: {done.stderr[-3000:]}"
        return config, json.loads(done.stdout)
    with ThreadPoolExecutor(2) as pool:
        return dict(pool.map(one, CONFIGS))


@pytest.mark.parametrize("kernel,simd", CONFIGS)
def test_every_reference_run_gives_the_stored_numbers(machine_runs, kernel, simd):
    report = machine_runs[(kernel, simd)]
    if isinstance(report, str):
        pytest.skip(report)
    # the configuration is the one asked for
    assert report["kernel"].lower() == kernel.lower() or kernel == "Prescott", report["kernel"]
    wants_avx512 = simd != "no AVX-512" and "avx512f" in cpu_flags()
    assert avx512_target(report["exp_target"]) == wants_avx512, report["exp_target"]
    default = machine_runs[("Haswell", "all SIMD")]
    if not isinstance(default, str):
        # the C library's variant: the default one but in the configuration that asks for SSE2
        same = report["libm_probe"] == default["libm_probe"]
        if simd == LIBM_SSE2 and same:
            pytest.skip("exp rounds the probe's argument alike in both variants of this C "
                        "library: which one ran is not known")
        assert same == (simd != LIBM_SSE2), report["libm_probe"]
    stored = reference_digests.stored()
    compared = reference_digests.event_quantities if simd == LIBM_SSE2 else dict
    moved = {case: sorted(key for key, value in compared(digests).items()
                          if stored[case][key] != value)
             for case, digests in report["digests"].items()}
    assert not {case: keys for case, keys in moved.items() if keys}


def test_the_fmu_gives_the_same_outputs_in_every_configuration(machine_runs):
    reports = [r for (_, simd), r in machine_runs.items()
               if not isinstance(r, str) and simd != LIBM_SSE2]
    assert len(reports) >= 2, "fewer than two configurations ran: nothing compared"
    assert len({json.dumps(r["fmu"], sort_keys=True) for r in reports}) == 1, \
        {config: r["fmu"] if not isinstance(r, str) else r for config, r in machine_runs.items()}
    assert len({r["kernel"] for r in reports}) >= min(2, len(reports))


def test_no_method_3_run_is_pinned_by_digest():
    assert not [case for case in reference_digests.stored() if case.startswith("method 3")]


def test_random_scenes_give_the_python_marchs_numbers_in_every_configuration(machine_runs):
    """Random scenes stepped (with and without early return) and sampled through run(), with the
    compiled march of bounces in every configuration: the numbers of the Python march here, to
    the bit (the C library's SSE2 variants aside: their states may differ in the last bits)."""
    python_march = random_scenes.digest(random_cases(), compiled=False)
    reports = {config: r for config, r in machine_runs.items()
               if not isinstance(r, str) and config[1] != LIBM_SSE2}
    assert reports, "no configuration ran"
    for config, report in reports.items():
        assert report["random"] == python_march, config
