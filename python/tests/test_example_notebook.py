"""The example notebook (python/examples/lab.ipynb) runs from top to bottom in a fresh kernel,
with nbclient, and draws its figure. Skipped without nbclient, nbformat and ipykernel, unless
SPHERESTEP_REQUIRE_NOTEBOOK=1 (as .ci/python sets, having installed them)."""

import os

import pytest

from conftest import ROOT

NOTEBOOK = ROOT / "python" / "examples" / "lab.ipynb"


def _need(name):
    if os.environ.get("SPHERESTEP_REQUIRE_NOTEBOOK") == "1":
        return __import__(name)
    return pytest.importorskip(name)


def test_the_example_notebook_runs_and_draws(tmp_path):
    nbformat = _need("nbformat")
    nbclient = _need("nbclient")
    _need("ipykernel")
    _need("matplotlib")
    nb = nbformat.read(NOTEBOOK, as_version=4)
    # the kernel starts in a scratch folder: the notebook names no file of the repository
    client = nbclient.NotebookClient(
        nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}
    )
    client.execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    pictures = [o for o in outputs if "image/png" in o.get("data", {})]
    assert len(pictures) == 1
    # the plan shows as a table
    assert any("<table" in o.get("data", {}).get("text/html", "") for o in outputs)
