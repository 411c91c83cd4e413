"""The sweep's one exception."""

from __future__ import annotations

from ..runspec import SpecError


class SweepError(SpecError):
    """A sweep cannot start or continue: a bad grid or setting, a grid larger than allowed, an
    output file written by a different sweep or damaged, a missing optional dependency. Raised
    before anything is run or written; the message says what to change."""
