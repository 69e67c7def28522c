"""The book's Python samples against the package: the errors `docs/python.md` shows (its
`text` blocks marked `<!-- output: python-errors -->` and `python-replace-errors`) are the ones raised today, word for word
(`tests/docs.rs` checks the command line's samples)."""

import numpy as np
import pytest

import spherestep
from conftest import ROOT, SCENARIOS


def _sample(name):
    """The lines of the `text` block after `<!-- output: NAME ... -->` in docs/python.md."""
    lines = (ROOT / "docs" / "python.md").read_text().splitlines()
    at = next(i for i, l in enumerate(lines) if l.startswith(f"<!-- output: {name} "))
    assert lines[at + 1] == "```text"
    end = lines.index("```", at + 2)
    return lines[at + 2 : end]


@pytest.mark.parametrize("name", ["python-errors", "python-replace-errors"])
def test_the_errors_the_book_shows_are_raised(name):
    lines = _sample(name)
    assert len(lines) >= 2 and len(lines) % 2 == 0, lines
    sc = spherestep.Scenario.load(str(SCENARIOS / "prototype.toml"))
    names = {"np": np, "spherestep": spherestep, "sc": sc, "motor": sc.motor()}
    for call, shown in zip(lines[::2], lines[1::2]):
        assert call.startswith(">>> "), call
        assert shown.startswith("spherestep.Error: "), shown
        with pytest.raises(spherestep.Error) as e:
            eval(call[4:], names)
        assert f"spherestep.Error: {e.value}" == shown, call
