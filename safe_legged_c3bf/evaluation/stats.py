"""Confidence intervals of the evaluation's rates (collision, fall, goal, success).

A rate of ``k`` events in ``n`` valid runs carries the exact (Clopper-Pearson) 95 % interval
of a binomial proportion, from :func:`scipy.stats.binomtest`: it never undercovers, which is
what a safety claim needs (Wilson's interval is shorter but can undercover near 0 and 1).
:func:`upper_bound` is the one-sided bound a campaign supports ("the collision rate is below
this at 95 % confidence"); :func:`bound_sentence` states it in words. Rates are fractions in
[0, 1].
"""

from __future__ import annotations

import operator

from scipy.stats import binomtest

#: Confidence level of every interval and bound.
CONFIDENCE = 0.95


def interval(k: int, n: int, confidence: float = CONFIDENCE) -> tuple[float, float] | None:
    """Two-sided Clopper-Pearson interval (low, high) of ``k`` events in ``n`` runs.

    None when ``n`` is 0 (no runs: no rate). Raises ValueError if not 0 <= k <= n.
    """
    _check(k, n)
    if n == 0:
        return None
    ci = binomtest(int(k), int(n)).proportion_ci(confidence_level=confidence, method="exact")
    return float(ci.low), float(ci.high)


def upper_bound(k: int, n: int, confidence: float = CONFIDENCE) -> float | None:
    """One-sided Clopper-Pearson upper bound of the rate of ``k`` events in ``n`` runs.

    The rate is below it with probability ``confidence``; e.g. 0 in 50 runs gives 5.8 % at
    95 % (the "rule of three": about 3 / n for k = 0). None when ``n`` is 0.
    """
    _check(k, n)
    if n == 0:
        return None
    ci = binomtest(int(k), int(n), alternative="less").proportion_ci(confidence_level=confidence,
                                                           method="exact")
    return float(ci.high)


def bound_sentence(k: int, n: int, what: str = "collision",
                   confidence: float = CONFIDENCE) -> str:
    """The bound a campaign supports, in words.

    E.g. "0 collisions in 50 runs: collision rate < 5.8 % at 95 % confidence (one-sided
    Clopper-Pearson; 95 % interval 0.0–7.1 %)".
    """
    _check(k, n)
    if n == 0:
        return f"no valid runs: no bound on the {what} rate"
    hi = upper_bound(k, n, confidence)
    lo2, hi2 = interval(k, n, confidence)
    plural = "" if k == 1 else "s"
    runs = "run" if n == 1 else "runs"
    level = f"{100 * confidence:g} %"
    detail = f"{level} interval {_pct(lo2, unit=False)}–{_pct(hi2)}"
    if k == n:  # every run had one: no upper bound below 100 %
        return f"{k} {what}{plural} in {n} {runs}: no bound below 100 % ({detail})"
    return (f"{k} {what}{plural} in {n} {runs}: {what} rate < {_pct(hi)} at {level} "
            f"confidence (one-sided Clopper-Pearson; {detail})")


def _pct(x: float, unit: bool = True) -> str:
    """A fraction as a percentage with one decimal ("7.1 %")."""
    return f"{100 * x:.1f}" + (" %" if unit else "")


def _check(k: int, n: int) -> None:
    try:
        ok = 0 <= operator.index(k) <= operator.index(n)
    except TypeError:
        ok = False
    if not ok or isinstance(k, bool) or isinstance(n, bool):
        raise ValueError(f"need integers 0 <= k <= n, got k={k!r}, n={n!r}")
