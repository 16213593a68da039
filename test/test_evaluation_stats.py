"""95 % intervals of the evaluation's rates and the collision-rate bound of a campaign."""

from __future__ import annotations

import csv

import pytest
from test_evaluation import synthetic_records

from safe_legged_c3bf.evaluation import stats
from safe_legged_c3bf.evaluation.metrics import RATES, SUMMARY_CSV_COLUMNS, summarize_group
from safe_legged_c3bf.evaluation.results import write_results


def test_clopper_pearson_known_values():
    # 0 of 50: the two-sided upper end is 1 - 0.025**(1/50), the one-sided 1 - 0.05**(1/50).
    assert stats.interval(0, 50) == pytest.approx((0.0, 1 - 0.025 ** (1 / 50)))
    assert stats.upper_bound(0, 50) == pytest.approx(1 - 0.05 ** (1 / 50))
    assert stats.upper_bound(0, 50) == pytest.approx(0.0582, abs=1e-4)
    assert stats.interval(50, 50) == pytest.approx((0.025 ** (1 / 50), 1.0))
    lo, hi = stats.interval(3, 50)  # tabulated exact interval: 1.25 %-16.55 %
    assert lo == pytest.approx(0.01255, abs=1e-4) and hi == pytest.approx(0.16548, abs=1e-4)
    assert stats.upper_bound(0, 1000) == pytest.approx(0.0030, abs=1e-4)  # rule of three


def test_interval_contains_the_rate_and_shrinks_with_runs():
    for n in (1, 7, 50, 400):
        for k in sorted({0, 1, n // 2, n}):
            lo, hi = stats.interval(k, n)
            assert 0.0 <= lo <= k / n <= hi <= 1.0
            assert stats.upper_bound(k, n) <= hi + 1e-12  # one-sided is the tighter
    assert stats.interval(5, 100)[1] - stats.interval(5, 100)[0] < (
        stats.interval(1, 20)[1] - stats.interval(1, 20)[0])


def test_no_runs_and_bad_counts():
    assert stats.interval(0, 0) is None and stats.upper_bound(0, 0) is None
    assert "no valid runs" in stats.bound_sentence(0, 0)
    for k, n in ((3, 2), (-1, 5), (1.5, 3), (True, 3)):
        with pytest.raises(ValueError):
            stats.interval(k, n)


def test_bound_sentence():
    text = stats.bound_sentence(0, 50)
    assert text.startswith("0 collisions in 50 runs: collision rate < 5.8 % at 95 % confidence")
    assert "0.0–7.1 %" in text
    assert stats.bound_sentence(1, 1).startswith("1 collision in 1 run: no bound below 100 %")
    assert "fall rate < " in stats.bound_sentence(2, 200, "fall")


def test_summary_rows_carry_intervals_and_the_bound(tmp_path):
    records = synthetic_records()
    group = [r for r in records if r["robot"] == "quadruped" and r["filter"] == "off"]
    row = summarize_group(group)
    for key in RATES:
        assert row[f"{key}_lo"] <= row[key] <= row[f"{key}_hi"]
    assert row["collision_rate"] == 1.0 and row["collision_rate_lo"] == pytest.approx(0.158, 1e-2)
    assert summarize_group([])["collision_rate_lo"] is None

    paths = write_results(records, tmp_path, figures=False)
    with open(paths["summary"], newline="") as f:
        rows = list(csv.DictReader(f))
    assert rows and set(SUMMARY_CSV_COLUMNS) <= set(rows[0])
    for r in rows:
        for key in RATES:
            if r[key]:
                assert float(r[f"{key}_lo"]) <= float(r[key]) <= float(r[f"{key}_hi"])
    md = paths["markdown"].read_text()
    assert "95 % Clopper-Pearson interval" in md
    assert "Collision-rate bounds the campaign supports" in md
    assert "quadruped, filter on: 0 collisions in 2 runs: collision rate < 77.6 %" in md
    assert "100 % (15.8–100.0)" in md  # the unfiltered quadruped collided in both runs
