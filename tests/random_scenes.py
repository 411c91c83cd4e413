"""Random scenes as ``tools/random_search.py --scales --flows`` draws them, and what the exact
method reports for them with its compiled march of bounces or with the Python march alone: each
step's numbers (or the refusal) and every impact, stepped at the scene's step h (optionally with
early return), and every sample of run() every h. tests/solvers/exact/test_bounces.py compares
the two paths on them; tests/test_machine_matrix.py compares a fixed draw in every machine
configuration."""

from __future__ import annotations

import dataclasses
import hashlib
import json

import pytest
from hypothesis import HealthCheck, given, seed, settings
from hypothesis import strategies as st

from iceimpact import ParameterError, Scene, Simulator, SolverError, run
from iceimpact.solvers.exact import EventSolver
from random_search import FLOWS, flow_at, scale_scenes

#: The strategy of a case: (scene, step h s, flow sequence, its signs).
CASES = st.tuples(scale_scenes(1), st.sampled_from([1e-3, 1e-2, 0.1, 1.0]),
                  st.sampled_from(FLOWS), st.lists(st.booleans(), min_size=1, max_size=8))


def _bits(values) -> list[str]:
    return [float(v).hex() for v in values]


def stepped(scene: Scene, h: float, flow: str, signs: list[bool], compiled: bool,
            early: bool = False, steps: int = 300) -> tuple:
    """Each step's state, impulse, impact count and sticking flag (or the refusal), and the
    impacts, stepping at h for 3 s at most."""
    out: list = []
    sim = None
    try:
        sim = Simulator(scene)
        if not compiled:
            sim.solver.bounces = None
        u0 = scene.flow_u if scene.flow_u != 0.0 else 0.1
        for i in range(max(1, min(steps, round(3.0 / h)))):
            report = sim.advance(h, flow_at(flow, i, u0, signs), stop_at_event=early)
            s = sim.solver.state
            out.append(_bits((sim.t, s.x, s.v, s.z, s.w, report.impulse))
                       + [sim.impact_count, sim.solver.sticking])
    except (ParameterError, SolverError) as exc:
        out.append(f"{type(exc).__name__}: {exc}")
    impacts = [] if sim is None else [_bits(i) for i in sim.impacts]
    return tuple(map(str, out)), tuple(map(str, impacts))


def kernel_is_the_python_march(scene: Scene, start: float, kernel, advance: float,
                               times, march=None) -> int:
    """From ``start`` (s), a Simulator whose march of bounces is ``kernel`` (``bounce_march`` or
    a form of it, run as given) in a ``march`` (default ``BounceMarch``; ``ModalBounceMarch``
    for the modes) against one with the Python march alone: stepped ``advance`` (s), then 0.5 s
    with early return, then sampled at ``times``; asserts every impact and sample equal to the
    bit and returns the impact count."""
    from iceimpact.solvers.exact.bounces import BounceMarch
    march = BounceMarch if march is None else march
    first = Simulator(scene)
    first.advance(start)
    reference, marched = Simulator(scene), Simulator(scene)
    reference.restore(first.save())
    marched.restore(first.save())
    reference.solver.bounces = None
    marched.solver.bounces = march(marched.solver, kernel)
    for sim in (reference, marched):
        sim.advance(advance)
        sim.advance(0.5, stop_at_event=True)
    count = len(marched.impacts)
    assert [_bits(i) for i in marched.impacts] == [_bits(i) for i in reference.impacts]
    a, b = reference.sample(times), marched.sample(times)
    for key in ("x", "v", "z", "w", "impulse"):
        assert _bits(getattr(a, key)) == _bits(getattr(b, key))
    if a.modal is not None:  # (the modal structure's modal states at the samples)
        assert _bits(a.modal.ravel()) == _bits(b.modal.ravel())
    assert [_bits(i) for i in marched.impacts] == [_bits(i) for i in reference.impacts]
    return count


def sampled(scene: Scene, t_end: float, dt: float, compiled: bool) -> tuple:
    """run()'s every sample and impact (or the refusal)."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(EventSolver, "COMPILED_BOUNCES", compiled)
        try:
            r = run(scene, t_end, dt=dt)
        except (ParameterError, SolverError) as exc:
            return (f"{type(exc).__name__}: {exc}",)
    return tuple(tuple(_bits(getattr(r, key))) for key in ("t", "x", "v", "z", "w", "impulse")) + (
        tuple(r.sticking.tolist()), tuple(_bits(r.impacts.view(float))))


def draw(examples: int, seed_value: int) -> list[tuple]:
    """``examples`` cases of :data:`CASES`, the same in every process (a fixed seed)."""
    cases: list[tuple] = []

    @seed(seed_value)
    @settings(max_examples=examples, deadline=None, database=None, derandomize=False,
              suppress_health_check=list(HealthCheck))
    @given(case=CASES)
    def collect(case):
        cases.append(case)
    collect()
    return cases


def digest(cases: list[tuple], compiled: bool) -> str:
    """One SHA-256 of every case stepped (with and without early return) and sampled."""
    h = hashlib.sha256()
    for scene, step, flow, signs in cases:
        for early in (False, True):
            h.update(json.dumps(stepped(scene, step, flow, signs, compiled, early)).encode())
        h.update(json.dumps(sampled(scene, 3.0, step, compiled)).encode())
    return h.hexdigest()


def to_json(cases: list[tuple]) -> str:
    """The cases as JSON (every scene field at full precision), for another process."""
    return json.dumps([[dataclasses.asdict(scene), h, flow, signs]
                       for scene, h, flow, signs in cases])


def from_json(text: str) -> list[tuple]:
    """The cases of :func:`to_json`."""
    return [(Scene(**fields), h, flow, signs) for fields, h, flow, signs in json.loads(text)]
