"""What a campaign says: pass rates with confidence intervals, figure distributions,
worst trials, which inputs drive the failures, throughput; the HTML page.

Pass rates carry the Wilson score interval (95 %): for k passes in n trials, p = k/n,

    centre = (p + z^2 / 2n) / (1 + z^2 / n),
    half   = z sqrt(p (1 - p) / n + z^2 / 4n^2) / (1 + z^2 / n),   z = 1.96,

which stays inside [0, 1] and is not degenerate at 0 or n passes. Event counts per
flight hour (``false_alarms``) carry the exact one-sided Poisson upper bound: with k
events in T hours, the rate below which k or fewer events have probability 5 %,
chi2.ppf(0.95, 2k + 2) / 2T (for k = 0: 3.0 / T).
"""
from __future__ import annotations

import math


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    if n == 0:
        return 0.0, 1.0
    p = k / n
    d = 1.0 + z * z / n
    c = (p + z * z / (2 * n)) / d
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return max(0.0, c - h), min(1.0, c + h)


def poisson_upper(k: int, exposure: float, conf: float = 0.95) -> float:
    """One-sided upper confidence bound on a Poisson rate: k events in ``exposure``."""
    from scipy.stats import chi2
    return float(chi2.ppf(conf, 2 * k + 2) / 2.0 / exposure) if exposure > 0 else math.inf


def criteria_names(store) -> list[str]:
    return [c[len("criterion."):] for c in store.columns() if c.startswith("criterion.")]


def pass_rates(store) -> list[tuple[str, int, int, float, float]]:
    """(name, passed, n, low, high) for every criterion and "all" (errors count as not
    passed; ``n`` is every stored trial)."""
    db = store.db
    n = db.execute("SELECT count(*) FROM trials").fetchone()[0]
    out = []
    k = db.execute("SELECT count(*) FROM trials WHERE passed AND error = ''").fetchone()[0]
    out.append(("all", k, n, *wilson(k, n)))
    for name in criteria_names(store):
        k = db.execute(f'SELECT count(*) FROM trials WHERE "criterion.{name}"').fetchone()[0]
        out.append((name, k, n, *wilson(k, n)))
    return out


def false_alarm_rate(store) -> dict | None:
    """Fault monitor false alarms per flight hour over the stored trials (with no error)."""
    cols = store.columns()
    if "false_alarms" not in cols:
        return None
    k, sim = store.db.execute("SELECT sum(false_alarms), sum(sim_s) FROM trials WHERE error = ''").fetchone()
    if not sim:
        return None
    hours = sim / 3600.0
    k = int(k or 0)
    return {"false_alarms": k, "flight_hours": hours, "per_hour": k / hours,
            "upper95_per_hour": poisson_upper(k, hours)}


def pass_summary(store) -> list[str]:
    lines = []
    n_err = store.db.execute("SELECT count(*) FROM trials WHERE error <> ''").fetchone()[0]
    for name, k, n, lo, hi in pass_rates(store):
        lines.append(f"{name:>24}: {k}/{n} passed ({100 * k / max(n, 1):.1f} %, 95 % CI "
                     f"{100 * lo:.1f}-{100 * hi:.1f} %)")
    lines.append(f"{'errors':>24}: {n_err}")
    fa = false_alarm_rate(store)
    if fa is not None:
        lines.append(f"{'false alarms':>24}: {fa['false_alarms']} in {fa['flight_hours']:.2f} flight hours: "
                     f"{fa['per_hour']:.3f} per hour, 95 % upper bound {fa['upper95_per_hour']:.3f} per hour")
    return lines
