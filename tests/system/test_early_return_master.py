"""FMI 3.0 early return in the coupled system, through the FMUs: the masters of
examples/system/early_return.py (IceImpact3.fmu with structure.model = 2 and ModalStructure3.fmu
in FMPy) against IceImpact's own monolithic run and against the same masters over the core
(benchmarks/coupling_early_return.py's ``core_master``: Simulator with ``stop_at_event`` and the
independent ExactSdof).

Scenes: benchmarks/coupling.py's impacting floe (M = 1200 kg, e = 0.7), whose first 16 impacts
(to its first chattering sequence, before 3.1 s) time the masters, and its heavy floe (M = 4800
kg, e = 0.3), which rides on the structure and separates from it.
"""

from __future__ import annotations

from pathlib import Path

import coupling_early_return as bench
import numpy as np
import pytest
from early_return import early_return_master, impact_time_error

from iceimpact import Scene
from iceimpact.simulator import run

pytest.importorskip("fmpy")

IMPACTING, HEAVY = (Scene(**values) for values in bench.SCENES.values())
#: The first chattering sequence of the impacting scene ends at 3.06 s; the ice then rides on the
#: structure until 3.16 s.
T_IMPACTS = 3.1
#: FMU against core: the same arithmetic but for the structures' rounding (closed-form modal
#: steps against a matrix exponential), measured at 3e-13 (x, relative to the peak) and 4e-13 s
#: (impact times) on these runs; the bounds leave four orders of magnitude and more.
X_AGREEMENT, TIME_AGREEMENT = 1e-8, 1e-9
#: The floe's and the structure's FMI time at an exchange: the same sums, so equal; a few
#: rounding steps allowed.
EXCHANGE_TOLERANCE = 1e-12


def fmu(fmus3: Path, scene: Scene, t_end: float, h: float, master: str, **options) -> dict:
    return early_return_master(fmus3, t_end, h, master, ice=bench.ice_values(scene),
                               flow_u=scene.flow_u, **options)


def x_error(result: dict, mono) -> float:
    return float(np.max(np.abs(result["x"] - mono.x)) / np.max(np.abs(mono.x)))


@pytest.fixture(scope="module")
def runs(fmus3) -> dict:
    """Every FMU run the tests look at, each once (about 4 s)."""
    return {
        ("plain", 1e-3, T_IMPACTS): fmu(fmus3, IMPACTING, T_IMPACTS, 1e-3, "plain"),
        ("early", 1e-3, T_IMPACTS): fmu(fmus3, IMPACTING, T_IMPACTS, 1e-3, "early"),
        ("plain", 1e-3, 6.0): fmu(fmus3, IMPACTING, 6.0, 1e-3, "plain"),
        ("early+approach", 1e-2, 6.0): fmu(fmus3, IMPACTING, 6.0, 1e-2, "early+approach",
                                           trace=True),
        ("heavy early", 1e-3, 6.0): fmu(fmus3, HEAVY, 6.0, 1e-3, "early", trace=True),
    }


def test_early_return_times_the_impacts_better_than_plain(runs):
    """At the same 1 ms step the early master meets all 16 impacts within 2 ms of the monolithic
    run's (measured: 1.4 ms; its error is the structure's, not the step's); the plain master,
    which holds each impact's impulse over its step, meets 12 of them, the matched ones more than
    10 times further off (measured: 55 ms)."""
    mono = run(IMPACTING, T_IMPACTS, dt=1e-3)
    # the monolithic run follows the first Zeno sequence to its end (61 impacts by 3.1 s); with
    # an external structure it is closed at the chatter time, at its 16th impact
    assert len(mono.impacts) == 61
    reference = mono.impacts["t"][:16]
    early = runs[("early", 1e-3, T_IMPACTS)]["impacts"]
    plain = runs[("plain", 1e-3, T_IMPACTS)]["impacts"]
    assert len(early) == len(reference)
    early_dt, timed = impact_time_error(early, reference)
    assert timed == 16 and early_dt < 2e-3, early_dt
    plain_dt, timed = impact_time_error(plain, reference)
    assert timed >= 8 and plain_dt > 10 * early_dt, (plain_dt, early_dt)


def test_early_return_with_approach_at_10_ms_beats_plain_at_1_ms(runs):
    """The goal: with early return (and short approaches), a 10 ms communication step is at
    least as accurate as 1 ms without (measured: 2.2 % against 4.6 %)."""
    approach = x_error(runs[("early+approach", 1e-2, 6.0)], run(IMPACTING, 6.0, dt=1e-2))
    plain = x_error(runs[("plain", 1e-3, 6.0)], run(IMPACTING, 6.0, dt=1e-3))
    assert approach <= plain, (approach, plain)
    assert plain < 0.06  # the reference row itself: 4.6 %


@pytest.mark.parametrize("key", [("early+approach", 1e-2, 6.0), ("heavy early", 1e-3, 6.0)])
def test_every_early_return_is_a_contact_event(runs, key):
    """Each early return is at an impact (contact.count grew and contact.t_last is the time the
    step returned at) or at a separation (the ice at the structure, contact.gap = 0, and no
    longer riding); the heavy floe's run has both kinds."""
    kinds = []
    for t_start, reached, before, after, t_last, _, riding, gap in runs[key]["returns"]:
        assert t_start < reached
        if after > before and t_last == reached:
            kinds.append("impact")
        else:
            assert gap == 0.0 and not riding, (t_start, reached, before, after, t_last, gap)
            kinds.append("separation")
    assert "impact" in kinds
    if key[0] == "heavy early":
        assert "separation" in kinds


@pytest.mark.parametrize("key", [("early+approach", 1e-2, 6.0), ("heavy early", 1e-3, 6.0)])
def test_floe_and_structure_times_agree_at_every_exchange(runs, key):
    exchanges = runs[key]["exchanges"]
    assert len(exchanges) > round(6.0 / key[1])  # the grid points and the early returns
    assert np.max(np.abs(exchanges[:, 0] - exchanges[:, 1])) <= EXCHANGE_TOLERANCE


@pytest.mark.parametrize("key", [("plain", 1e-3, T_IMPACTS), ("early", 1e-3, T_IMPACTS),
                                 ("early+approach", 1e-2, 6.0), ("heavy early", 1e-3, 6.0)])
def test_fmus_equal_the_core_master(runs, key):
    """Through the FMUs the masters give what the same master over the core gives: the FMI
    layer, the early return, the state rollback and ModalStructure3 add nothing but the
    structures' rounding."""
    master, h, t_end = key
    scene = HEAVY if master.startswith("heavy") else IMPACTING
    master = master.removeprefix("heavy ")
    result = runs[key]
    core = bench.core_master(scene, t_end, h, master)
    peak = np.max(np.abs(run(scene, t_end, dt=h).x))
    assert np.max(np.abs(result["x"] - core["x"])) <= X_AGREEMENT * peak
    assert result["count"] == core["count"]
    np.testing.assert_allclose(result["impacts"], core["impacts"], rtol=0, atol=TIME_AGREEMENT)
    assert result["impulse"] == pytest.approx(core["impulse"], rel=1e-9)
