"""Tests of rig F, and what its tests share."""

from __future__ import annotations

import copy


def golden_view(document: dict) -> dict:
    """A fit-result JSON document with each table (``{"columns": [...], "data": [[row], ...]}``) read
    as a list of records, so that a golden file's tolerance rules can name a column
    (``tables.points[*].restitution``): the rules match key paths, in which list indices are
    wildcards, so the columns of a row list could not be told apart."""
    out = copy.deepcopy(document)
    for name, table in (out.get("tables") or {}).items():
        out["tables"][name] = [dict(zip(table["columns"], row, strict=True)) for row in table["data"]]
    return out
