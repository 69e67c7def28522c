"""Fixtures of the spherestep Python tests: the repository's scenarios and the command line
(target/release/spherestep, built by `cargo test --release` in .ci/run; built here with
`cargo build --release` when missing; SPHERESTEP_BIN names another)."""

import csv
import io
import json
import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = ROOT / "scenarios"


def _binary() -> Path:
    given = os.environ.get("SPHERESTEP_BIN")
    if given:
        return Path(given)
    path = ROOT / "target" / "release" / "spherestep"
    if not path.exists():
        subprocess.run(["cargo", "build", "--release"], cwd=ROOT, check=True)
    return path


@pytest.fixture(scope="session")
def cli():
    """Runs the command line; returns its standard output (text). A failure fails the test
    with the command's standard error."""
    binary = _binary()

    def run(*args, ok=True):
        p = subprocess.run(
            [str(binary), *map(str, args)], cwd=ROOT, capture_output=True, text=True
        )
        if ok and p.returncode != 0:
            pytest.fail(f"spherestep {' '.join(map(str, args))} failed:\n{p.stderr}")
        return p.stdout

    return run


@pytest.fixture(scope="session")
def prototype_toml() -> Path:
    return SCENARIOS / "prototype.toml"


def read_csv(text: str):
    """A CSV's rows as dicts of strings (the command line writes floats in their shortest
    round-trip form, so float() of a field is the library's f64 exactly)."""
    return list(csv.DictReader(io.StringIO(text)))


def floats(rows, key):
    return [float(r[key]) for r in rows]


def read_json(text: str):
    return json.loads(text.strip().splitlines()[-1])
