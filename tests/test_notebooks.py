"""Execute every notebook: in short mode (JAXATT_SHORT=1) in the suite, where they are
documentation that must run; in full mode (JAXATT_SHORT=0) with `pytest --full-notebooks`, where
each asserts the numbers its text states (docs/testing.md)."""

import os
import pathlib

import nbformat
import pytest
from nbclient import NotebookClient


NOTEBOOKS = sorted((pathlib.Path(__file__).parents[1] / "notebooks").glob("*.ipynb"))


def _execute(path: pathlib.Path, tmp_path, monkeypatch, *, short: bool, timeout: int) -> None:
    monkeypatch.setenv("JAXATT_SHORT", "1" if short else "0")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.chdir(tmp_path)  # anything a notebook writes lands in a temporary folder
    nb = nbformat.read(path, as_version=4)
    client = NotebookClient(nb, timeout=timeout, kernel_name="python3")
    client.execute()  # raises CellExecutionError with the failing cell's traceback
    errors = [
        out
        for cell in nb.cells
        if cell.cell_type == "code"
        for out in cell.get("outputs", [])
        if out.get("output_type") == "error"
    ]
    assert not errors


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_notebook_runs_in_short_mode(path, tmp_path, monkeypatch):
    _execute(path, tmp_path, monkeypatch, short=True, timeout=600)


@pytest.mark.full_notebooks
@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_notebook_states_its_full_mode_numbers(path, tmp_path, monkeypatch):
    _execute(path, tmp_path, monkeypatch, short=False, timeout=1800)


def test_there_are_notebooks():
    assert any(p.name.startswith("00_") for p in NOTEBOOKS)
    assert os.path.isdir(pathlib.Path(__file__).parents[1] / "notebooks")
