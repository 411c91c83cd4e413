"""Counters of a method's work that tests bound (a search that walks without end fails)."""

from __future__ import annotations


def count_probes(monkeypatch, segment: type, limit: int, why: str) -> list[int]:
    """Count the calls of ``segment.probe`` (the root search's evaluations) into the returned
    one-element list, failing with ``why`` past ``limit`` (a search that walks without end)."""
    calls = [0]
    probe = segment.probe

    def counted(self, tau):
        calls[0] += 1
        assert calls[0] <= limit, why
        return probe(self, tau)
    monkeypatch.setattr(segment, "probe", counted)
    return calls
