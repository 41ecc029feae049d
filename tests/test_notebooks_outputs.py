"""The tutorials' stored outputs (``notebooks/*.ipynb``), which the documentation shows without executing
the notebooks: they were made by ``tools/execute_notebooks.py`` (every code cell executed, at least one
figure, no absolute path of a machine in any output) and each has its gallery thumbnail. Reads the
files only; the test command executes the notebooks themselves (nbmake)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))
THUMBNAILS = ROOT / "docs" / "tutorials_thumbnails"
#: An absolute path of a user's machine (POSIX home or temporary folders, macOS, Windows drives).
ABSOLUTE_PATH = re.compile(r"(?<![\w.])(/home/|/Users/|/root/|/tmp/|/work/|/var/folders/|/private/|[A-Za-z]:\\)")


def _texts(output: dict) -> list[str]:
    texts = []
    if "text" in output:
        texts.append("".join(output["text"]))
    for mime, value in output.get("data", {}).items():
        if mime.startswith("text/"):
            texts.append("".join(value) if isinstance(value, list) else str(value))
    texts.extend(output.get("traceback", []))
    return texts


def _load(path: Path) -> dict:
    return json.loads(path.read_text(encoding="utf-8"))


def test_every_notebook_is_found():
    assert len(NOTEBOOKS) >= 8


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_was_executed_in_order(path):
    code = [cell for cell in _load(path)["cells"] if cell["cell_type"] == "code"]
    counts = [cell.get("execution_count") for cell in code]
    assert all(isinstance(count, int) for count in counts), f"{path.name}: not every code cell executed: {counts}"
    assert counts == list(range(1, len(code) + 1)), f"{path.name}: cells executed out of order: {counts}"
    errors = [o for cell in code for o in cell.get("outputs", []) if o.get("output_type") == "error"]
    assert not errors, f"{path.name}: a stored output is an error"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_shows_a_figure(path):
    images = [o for cell in _load(path)["cells"] for o in cell.get("outputs", []) if "image/png" in o.get("data", {})]
    assert images, f"{path.name}: no figure among the stored outputs"
    assert (THUMBNAILS / f"{path.stem}.png").is_file(), f"{path.name}: no gallery thumbnail"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_no_output_holds_an_absolute_path(path):
    for index, cell in enumerate(_load(path)["cells"]):
        for output in cell.get("outputs", []):
            for text in _texts(output):
                match = ABSOLUTE_PATH.search(text)
                assert match is None, f"{path.name}, cell {index}: an output holds an absolute path ({match.group(0)})"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_no_run_metadata_is_stored(path):
    notebook = _load(path)
    assert "version" not in notebook["metadata"].get("language_info", {})
    assert not any("execution" in cell.get("metadata", {}) for cell in notebook["cells"])


def test_no_forced_backend_and_no_figure_closed():
    for path in NOTEBOOKS:
        source = "\n".join("".join(cell["source"]) for cell in _load(path)["cells"] if cell["cell_type"] == "code")
        assert "matplotlib.use(" not in source, f"{path.name}: forces a matplotlib backend"
        assert "plt.close(" not in source, f"{path.name}: closes a figure (it would not be shown)"


def test_gallery_lists_every_notebook():
    gallery = (ROOT / "docs" / "tutorials.md").read_text(encoding="utf-8")
    for path in NOTEBOOKS:
        assert f"tutorials/{path.stem}" in gallery, f"docs/tutorials.md does not list {path.name}"
        assert f"tutorials_thumbnails/{path.stem}.png" in gallery, f"docs/tutorials.md has no thumbnail of {path.name}"
