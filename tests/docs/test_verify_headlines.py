"""``make verify`` (examples/verify_headlines.py) passes on today's code and compares the headline
numbers it names (about 10 s)."""

from __future__ import annotations

from pathlib import Path

import verify_headlines

ROOT = Path(__file__).resolve().parents[2]


def test_verify_passes_and_compares_the_headlines(fmu: Path, monkeypatch, capsys) -> None:
    monkeypatch.setattr(verify_headlines, "FMU", fmu)
    assert verify_headlines.main() == 0
    out = capsys.readouterr().out
    for key in ("linear.fig2.exact.impacts", "linear.fig2.exact.sticking_since_s",
                "quadratic.a2.exact.sticking_since_s",
                "quadratic.a2.exact.dominant_frequency_mid_hz"):
        assert key in out, key
    assert "Figure 2 through the FMU gives the same measures" in out


def test_make_verify_runs_the_script() -> None:
    makefile = (ROOT / "Makefile").read_text()
    target = makefile.split("\nverify:", 1)[1].split("\n\n", 1)[0]
    assert "examples/verify_headlines.py" in target


def test_a_changed_number_fails(monkeypatch, tmp_path: Path) -> None:
    doc = tmp_path / "reproduction.md"
    text = verify_headlines.REPRODUCTION.read_text()
    anchor = "<!-- run:linear.fig2.exact.impacts -->"
    printed = text.split(anchor, 1)[0].rsplit(" ", 1)[1]
    doc.write_text(text.replace(printed + anchor, "15,000" + anchor, 1))
    monkeypatch.setattr(verify_headlines, "REPRODUCTION", doc)
    _, _, stale = verify_headlines.headline_numbers()
    assert any("linear.fig2.exact.impacts" in line for line in stale)

