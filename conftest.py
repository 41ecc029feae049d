"""Repository-wide test configuration (the root, so that it sees the items of every test path).

Executed notebooks (nbmake items collected from ``notebooks/``) are slow tests: ``pytest -m "not slow"``
is the warm loop of under a minute; CI runs everything. The hook lives here and not in
``tests/conftest.py`` because a conftest below the root is not loaded for a run of ``notebooks/`` alone.
"""

from __future__ import annotations

import pytest


def pytest_collection_modifyitems(config, items):
    slow = pytest.mark.slow
    for item in items:
        if item.path.suffix == ".ipynb":
            item.add_marker(slow)
