"""ImpactLog (solvers/impact_log.py): the impacts a solver lists, appended one by one or in
blocks of rows, read back as Impact records or as one array, cut back for a rollback."""

from __future__ import annotations

import numpy as np
import pytest

from iceimpact import Scene, Simulator, run
from iceimpact.physics.contact import Impact
from iceimpact.simulator import impacts_array
from iceimpact.solvers.impact_log import ImpactLog


def _impact(i: int) -> Impact:
    return Impact(float(i), 0.1 * i, -1.0, 2.0 + i, 1.5, -0.5, 3.0 * i, 1.0)


def test_appended_and_block_impacts_keep_their_order():
    log = ImpactLog()
    reference = []
    for k in range(5):
        log.append(_impact(k))
        reference.append(_impact(k))
    block = [_impact(k) for k in range(5, 3000)]
    log.extend_rows(np.array(block))
    reference += block
    log.append(_impact(3000))
    reference.append(_impact(3000))
    assert len(log) == 3001 and log == reference and list(log) == reference
    assert log[0] == reference[0] and log[-1] == reference[-1] and log[2999] == reference[2999]
    assert log[10:13] == reference[10:13]
    assert isinstance(log[7], Impact) and log[7].approach_speed == 10.0
    assert impacts_array(log).tobytes() == impacts_array(reference).tobytes()
    with pytest.raises(IndexError):
        log[3001]


@pytest.mark.parametrize("keep", [0, 3, 5, 6, 2000, 3001])
def test_a_rollback_drops_the_last_impacts(keep):
    log = ImpactLog([_impact(k) for k in range(5)])
    log.extend_rows(np.array([_impact(k) for k in range(5, 3000)]))
    log.append(_impact(3000))
    del log[keep:]
    assert log == [_impact(k) for k in range(keep)]
    log.append(_impact(keep))
    assert log[-1] == _impact(keep) and len(log) == keep + 1
    log.clear()
    assert len(log) == 0 and log == [] and impacts_array(log).shape == (0,)


def test_only_the_end_can_be_dropped():
    log = ImpactLog([_impact(1), _impact(2)])
    with pytest.raises(TypeError, match="del log"):
        del log[0]


def test_a_run_lists_the_impacts_a_stepped_simulator_lists():
    """run()'s structured array and a stepped simulator's list hold the same impacts."""
    scene = Scene(ice_M=6400.0, flow_u=2.0)
    result = run(scene, 60.0, dt=0.5)
    sim = Simulator(scene)
    for _ in range(120):
        sim.advance(0.5)
    assert len(result.impacts) == sim.impact_count > 100
    assert result.impacts.tobytes() == impacts_array(list(sim.impacts)).tobytes()
