"""Shared by the CLI's tests: a CSV's rows, and a command expected to stop with a usage error."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from iceimpact.cli import main


def rows_of(path: Path) -> list[list[str]]:
    with open(path, newline="") as fh:
        return list(csv.reader(fh))


def usage_error(capsys, argv: list[str]) -> str:
    """Run ``main(argv)``, expect an argparse error (exit 2) and return stderr."""
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return err
