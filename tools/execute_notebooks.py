"""Execute the tutorials (``notebooks/*.ipynb``) and store their outputs in them, for the documentation.

The documentation build renders the notebooks without executing them (``nb_execution_mode = "off"`` in
``docs/conf.py``) and shows the outputs stored in the files; the test command executes every notebook
again (nbmake, which does not write back). This script is how those stored outputs are made: run it
after changing a notebook, or the package in a way that changes a notebook's output, and commit the
notebooks it rewrites together with the thumbnails.

For each notebook it

* executes it with nbclient in a fresh temporary working folder (what a notebook writes stays there),
  with numba's compilation notice turned off so that the output does not depend on the cache;
* writes the outputs back without timings or per-run metadata (``execution`` cell metadata, the
  Python version), so that a rerun changes the file only where an output changed;
* refuses to store an output that contains an absolute path of this machine (the working folder,
  the repository, the home folder, the user's name in a path);
* saves the notebook's first figure as a thumbnail, ``docs/tutorials_thumbnails/<notebook>.png``,
  for the gallery of ``docs/tutorials.md``;
* prints its wall time.

Usage, from the repository root (with the ``notebooks`` extra installed)::

    python tools/execute_notebooks.py                       # every notebook
    python tools/execute_notebooks.py notebooks/04_bounces.ipynb
"""

from __future__ import annotations

import argparse
import base64
import io
import os
import re
import sys
import tempfile
import time
from pathlib import Path

import nbformat
from nbclient import NotebookClient
from PIL import Image

ROOT = Path(__file__).resolve().parent.parent
NOTEBOOKS = ROOT / "notebooks"
THUMBNAILS = ROOT / "docs" / "tutorials_thumbnails"
#: Width of a gallery thumbnail [pixels].
THUMBNAIL_WIDTH = 480
#: Seconds a cell may run before the execution is abandoned.
CELL_TIMEOUT = 600
#: The metadata a stored notebook keeps (everything else is per-run: versions, widgets' state).
NOTEBOOK_METADATA = {
    "kernelspec": {"display_name": "Python 3", "language": "python", "name": "python3"},
    "language_info": {"name": "python"},
}
#: Absolute paths that must never appear in a stored output, whatever the machine.
ABSOLUTE_PATH = re.compile(r"(?<![\w.])(/home/|/Users/|/root/|/tmp/|/var/folders/|/private/|[A-Za-z]:\\\\)")


def _output_texts(cell: dict) -> list[str]:
    """The text of every output of a code cell (streams, text results, errors; not images)."""
    texts = []
    for output in cell.get("outputs", []):
        if "text" in output:
            texts.append("".join(output["text"]) if isinstance(output["text"], list) else output["text"])
        for mime, value in output.get("data", {}).items():
            if mime.startswith("text/") or mime == "application/json":
                texts.append("".join(value) if isinstance(value, list) else str(value))
        if output.get("output_type") == "error":
            texts.append("\n".join(output.get("traceback", [])))
    return texts


def machine_paths(*folders: Path) -> list[str]:
    """The absolute paths of this machine that must not appear in an output: the given folders (and
    their resolved forms), the home folder and the user's name inside a path."""
    found = {str(ROOT), str(Path.home())}
    for folder in folders:
        found.update((str(folder), str(folder.resolve())))
    user = os.environ.get("USER") or os.environ.get("USERNAME")
    if user:
        found.add(f"/{user}/")
    return sorted(p for p in found if p not in {"", "/"})


def leaked_paths(notebook: dict, forbidden: list[str]) -> list[str]:
    """Descriptions of the outputs that contain an absolute path (empty when there is none)."""
    problems = []
    for index, cell in enumerate(notebook["cells"]):
        for text in _output_texts(cell):
            hits = [p for p in forbidden if p in text]
            match = ABSOLUTE_PATH.search(text)
            if match:
                hits.append(match.group(0))
            if hits:
                problems.append(f"cell {index}: {', '.join(sorted(set(hits)))}")
    return problems


def first_figure(notebook: dict) -> bytes | None:
    """The PNG bytes of the notebook's first image output, or None."""
    for cell in notebook["cells"]:
        for output in cell.get("outputs", []):
            data = output.get("data", {})
            if "image/png" in data:
                value = data["image/png"]
                return base64.b64decode("".join(value) if isinstance(value, list) else value)
    return None


def write_thumbnail(png: bytes, target: Path, width: int = THUMBNAIL_WIDTH) -> None:
    """Write ``png`` scaled to ``width`` pixels (never enlarged) as an optimised PNG at ``target``."""
    image = Image.open(io.BytesIO(png)).convert("RGB")
    if image.width > width:
        image = image.resize((width, round(image.height * width / image.width)), Image.Resampling.LANCZOS)
    buffer = io.BytesIO()
    image.quantize(colors=256).save(buffer, format="PNG", optimize=True)  # a palette: a few tens of kB
    target.parent.mkdir(parents=True, exist_ok=True)
    if not target.exists() or target.read_bytes() != buffer.getvalue():
        target.write_bytes(buffer.getvalue())


def clean(notebook: dict) -> None:
    """Remove per-run metadata in place: execution timings of the cells, versions of the notebook."""
    notebook["metadata"] = {key: value for key, value in NOTEBOOK_METADATA.items()}
    for cell in notebook["cells"]:
        cell["metadata"].pop("execution", None)
        if cell["cell_type"] == "code":
            for output in cell.get("outputs", []):
                output.get("metadata", {}).pop("execution", None)


def execute(path: Path) -> float:
    """Execute the notebook at ``path`` in a temporary folder, store its outputs and its thumbnail;
    return the wall time [s]. Raises RuntimeError when a cell fails or an output holds a path."""
    notebook = nbformat.read(path, as_version=4)
    for cell in notebook.cells:  # start from a clean notebook: no stale output survives a failure
        if cell.cell_type == "code":
            cell.outputs, cell.execution_count = [], None
    with tempfile.TemporaryDirectory(prefix="impactid-notebook-") as folder:
        client = NotebookClient(notebook, timeout=CELL_TIMEOUT, kernel_name="python3", record_timing=False,
                                resources={"metadata": {"path": folder}})
        started = time.perf_counter()
        client.execute(env={**os.environ, "IMPACTID_COMPILE_NOTICE": "0", "PYDEVD_DISABLE_FILE_VALIDATION": "1"})
        seconds = time.perf_counter() - started
        problems = leaked_paths(notebook, machine_paths(Path(folder), Path(tempfile.gettempdir())))
    if problems:
        raise RuntimeError(f"an output holds an absolute path ({'; '.join(problems)}); print names relative "
                           f"to the working folder (executed in {seconds:.1f} s)")
    png = first_figure(notebook)
    if png is None:
        raise RuntimeError(f"no figure in the outputs; every tutorial shows one (executed in {seconds:.1f} s)")
    clean(notebook)
    nbformat.validate(notebook)
    text = nbformat.writes(notebook, version=4) + "\n"
    if path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")
    write_thumbnail(png, THUMBNAILS / f"{path.stem}.png")
    return seconds


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("notebooks", nargs="*", type=Path, help="notebooks to execute (default: notebooks/*.ipynb)")
    args = parser.parse_args(argv)
    paths = args.notebooks or sorted(NOTEBOOKS.glob("*.ipynb"))
    failed = 0
    total = 0.0
    for path in paths:
        try:
            seconds = execute(path.resolve())
        except Exception as error:  # report every notebook, then fail
            failed += 1
            lines = str(error).strip().splitlines() or [type(error).__name__]
            print(f"{path.name}: FAILED:", *lines[-12:], sep="\n    ", flush=True)
            continue
        total += seconds
        print(f"{path.name}: {seconds:.1f} s", flush=True)
    print(f"{len(paths) - failed} of {len(paths)} notebooks executed in {total:.1f} s", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
