"""The notebooks of examples/notebooks execute from top to bottom (nbclient),
so they never rot. MRCLAM data: as tests/python/test_mrclam.py (they fail,
not skip, without it)."""

from __future__ import annotations

import importlib
import os
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
NOTEBOOKS = sorted((ROOT / "examples" / "notebooks").glob("*.ipynb"))
DATA = Path(os.environ.get("BEARING_SLAM_DATA") or ROOT.parent / "shared" / "datasets" / "mrclam")


def test_the_notebooks_are_there() -> None:
    assert [p.name for p in NOTEBOOKS] == ["mrclam_robot3.ipynb", "quickstart.ipynb"]


@pytest.mark.slow
@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_executes(path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    nbclient = importlib.import_module("nbclient")  # installed by the dev/test extras
    nbformat = importlib.import_module("nbformat")

    monkeypatch.setenv("BEARING_SLAM_DATA", str(DATA))
    notebook = nbformat.read(path, as_version=4)
    assert all(not c.get("outputs") for c in notebook.cells if c.cell_type == "code"), (
        "commit notebooks without outputs"
    )
    t0 = time.perf_counter()
    client = nbclient.NotebookClient(
        notebook, timeout=300, kernel_name="python3", resources={"metadata": {"path": path.parent}}
    )
    client.execute()
    seconds = time.perf_counter() - t0
    assert seconds < 120.0, f"{path.name} took {seconds:.0f} s"
    images = [
        o
        for c in notebook.cells
        if c.cell_type == "code"
        for o in c.outputs
        if "image/png" in o.get("data", {})
    ]
    assert images, f"{path.name} shows no figure"
