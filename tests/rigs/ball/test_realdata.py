"""The real phyphox recordings (not in the repository): every file read and analysed.

Set ``IMPACTID_REALDATA_BOUNCES`` to the folder that holds ``pingpong_parquet/`` and
``unknown_ball/``; without it these tests are skipped.
"""

import os
from pathlib import Path

import pytest

from impactid.rigs.ball import TABLE_TENNIS, analyse_bounces, read_bounces

ROOT = os.environ.get("IMPACTID_REALDATA_BOUNCES")
pytestmark = pytest.mark.skipif(not ROOT or not Path(ROOT).is_dir(),
                                reason="set IMPACTID_REALDATA_BOUNCES to the real bounce recordings")


def _files(sub, pattern):
    return sorted((Path(ROOT) / sub).glob(pattern))


def test_every_file_is_read():
    files = _files("pingpong_parquet", "*.xlsx") + _files("unknown_ball", "*.xls")
    assert len(files) >= 40
    for path in files:
        rec = read_bounces(path)
        assert rec.times.size >= 3 and rec.resolution == pytest.approx(1 / 48000)


def test_table_tennis_drag_explains_most_of_the_slope():
    res = analyse_bounces(_files("pingpong_parquet", "*.xlsx"), ball=TABLE_TENNIS, chained=False)
    assert res.statistics["drops_refused"] == 0
    e = res["constant.e"]
    assert 0.93 < e.value < 0.97 and e.stderr < 0.002
    g_drag, g_vac = res.law_fits["linear"]["gamma"], res.no_drag_fits["linear"]["gamma"]
    assert g_vac.value > 2 * g_drag.value  # the apparent speed dependence is mostly drag
    assert res.statistics["intervals_rejected"] < 0.1 * res.statistics["intervals"]


def test_unknown_ball_without_drag():
    res = analyse_bounces(_files("unknown_ball", "*.xls"), chained=False)
    assert res.statistics["drops_refused"] <= 1
    assert 0.8 < res["constant.e"].value < 0.95
    assert any("no ball given" in n for n in res.notes)
