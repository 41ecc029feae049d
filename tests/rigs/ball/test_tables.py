"""Tables of several drops (one column or one sheet per trial, with or without a header row, blank
cells at the end of shorter columns) are read as several drops; a phyphox export stays one drop;
and a drop with a few faulty triggers is cleaned, not discarded."""

import numpy as np
import pandas as pd
import pytest

from impactid.rigs.ball import TABLE_TENNIS, analyse_bounces
from impactid.rigs.ball.readers import BounceFileError, read_drops
from impactid.rigs.ball.sequence import clean_sequence
from impactid.rigs.ball.synth import synth_drop, write_phyphox_xlsx


@pytest.fixture(scope="module")
def drops():
    return [synth_drop("constant", {"e": 0.9}, seed=s, ball=TABLE_TENNIS, height=0.25 + 0.1 * s, jitter=1e-4)
            for s in range(3)]


def _frame(drops, header="trial {k} (s)", scale=1.0, numbered=False):
    frame = pd.DataFrame({header.format(k=k + 1): pd.Series(scale * d.times) for k, d in enumerate(drops)})
    if numbered:
        frame.insert(0, "n", np.arange(1, len(frame) + 1))
    return frame


@pytest.mark.parametrize(("name", "write"), [
    ("columns.csv", lambda f, p: f.to_csv(p, index=False)),
    ("columns_ms.csv", None),
    ("numbered.xlsx", None),
    ("no_header.csv", None),
    ("decimal_comma.csv", None),
    ("sheets.xlsx", None),
])
def test_every_trial_is_a_drop(tmp_path, drops, name, write):
    path = tmp_path / name
    if name == "columns.csv":
        _frame(drops).to_csv(path, index=False)
    elif name == "columns_ms.csv":
        _frame(drops, "Lancio {k} (ms)", 1e3).to_csv(path, index=False)
    elif name == "numbered.xlsx":
        _frame(drops, numbered=True).to_excel(path, index=False)
    elif name == "no_header.csv":
        _frame(drops).to_csv(path, index=False, header=False)
    elif name == "decimal_comma.csv":
        _frame(drops).to_csv(path, index=False, sep=";", decimal=",")
    else:
        with pd.ExcelWriter(path) as book:
            for k, d in enumerate(drops):
                pd.DataFrame({"t": d.times}).to_excel(book, sheet_name=f"drop {k + 1}", index=False, header=False)
    recordings = read_drops(path)
    assert len(recordings) == len(drops)
    for rec, d in zip(recordings, drops):
        np.testing.assert_allclose(rec.times, d.times, atol=1e-9)
        assert rec.trial and rec.name.startswith(path.name)
    assert len({r.name for r in recordings}) == len(drops)
    res = analyse_bounces([path], ball=TABLE_TENNIS, chained=False)
    assert res.statistics["drops_analysed"] == len(drops) and res.statistics["files"] == 1
    assert res.bounces["file"].nunique() == len(drops)
    assert abs(res["constant.e"].value - 0.9) < 0.002


def test_a_phyphox_export_and_a_single_column_stay_one_drop(tmp_path, drops):
    assert len(read_drops(write_phyphox_xlsx(tmp_path / "phyphox.xlsx", drops[0].times))) == 1
    (tmp_path / "one.csv").write_text("time (s)\n" + "\n".join(f"{t:.6f}" for t in drops[0].times) + "\n")
    assert len(read_drops(tmp_path / "one.csv")) == 1
    # a time and an amplitude: one drop, the time column
    rows = "\n".join(f"{t:.6f},{a:.3f}" for t, a in zip(drops[0].times, np.linspace(1, 0.2, drops[0].times.size)))
    (tmp_path / "amplitude.csv").write_text("time,amplitude\n" + rows + "\n")
    assert len(read_drops(tmp_path / "amplitude.csv")) == 1


def test_a_trial_with_a_bad_cell_is_named(tmp_path, drops):
    frame = _frame(drops).astype(object)
    frame.iloc[4, 1] = -1.0  # not increasing
    path = tmp_path / "bad.xlsx"
    frame.to_excel(path, index=False)
    with pytest.raises(BounceFileError, match="bad.xlsx"):
        read_drops(path)


@pytest.mark.parametrize("seed", range(6))
def test_a_few_faults_are_cleaned_not_discarded(seed):
    """One or two spurious or missed triggers: the drop is kept, the faulty intervals flagged with
    their reason and the others used."""
    rng = np.random.default_rng(seed)
    drop = synth_drop("linear", {"e0": 0.95, "gamma": 0.02}, seed=seed, ball=TABLE_TENNIS,
                      height=float(rng.uniform(0.1, 0.4)), jitter=2e-4, missed=int(rng.integers(0, 2)),
                      spurious=int(rng.integers(1, 3)), echoes=1)
    seq = clean_sequence(drop.times, resolution=1 / 48000)
    assert not seq.refused
    table = seq.intervals
    flagged = table[~table["flag"].isin(["ok", "first"])]
    assert len(flagged) >= 1 and all(flagged["reason"].str.len() > 10)
    assert (table["flag"] == "ok").sum() >= drop.true_times.size - 3 * (len(flagged) + 1)
