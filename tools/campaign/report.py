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
from pathlib import Path


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


# --- the HTML page ----------------------------------------------------------------------

def auc(values_fail: list[float], values_pass: list[float]) -> float | None:
    """P(an input of a failed trial > that of a passed one) + P(equal) / 2 (the
    Mann-Whitney statistic over n_fail n_pass): 0.5 when the input does not separate
    failures from passes, near 0 or 1 when it drives them."""
    if not values_fail or not values_pass:
        return None
    import numpy as np
    f = np.asarray(values_fail, float)[:, None]
    p = np.asarray(values_pass, float)[None, :]
    return float(np.mean((f > p) + 0.5 * (f == p)))


def percentiles(v: list[float]) -> dict:
    import numpy as np
    a = np.asarray(v, float)
    return {"n": len(a), "p50": float(np.percentile(a, 50)), "p95": float(np.percentile(a, 95)),
            "p99": float(np.percentile(a, 99)), "max": float(a.max()), "min": float(a.min())}


def _esc(s) -> str:
    import html
    return html.escape(str(s))


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    return _esc(v)


_CSS = """body{font-family:sans-serif;max-width:1100px;margin:1em auto;padding:0 1em;color:#222}
table{border-collapse:collapse;margin:.5em 0}td,th{border:1px solid #bbb;padding:2px 8px;text-align:right}
th{background:#eee}td.l,th.l{text-align:left}code{font-size:85%;word-break:break-all}
img{max-width:100%;border:1px solid #ddd;margin:.3em 0}.fail{color:#b00}.pass{color:#070}"""

_IMG_CHECK = """<script>
// the page's own check that its pictures loaded (read by a headless browser)
window.addEventListener('load', function () {
  var imgs = Array.prototype.slice.call(document.images);
  var ok = imgs.filter(function (i) { return i.complete && i.naturalWidth > 0; }).length;
  document.body.setAttribute('data-images-loaded', ok + '/' + imgs.length);
});
</script>"""


def _share(cpu, wall) -> str:
    return f"{100 * cpu / wall:.0f} %" if cpu and wall else "-"


def _ratio(sim, cpu) -> str:
    return f"{sim / cpu:.1f}" if sim and cpu else "-"


def make_report(folder: Path) -> Path:
    """Write ``folder/report/index.html`` and its PNGs; the page's path."""
    import json

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .criteria import flatten
    from .execute import key_figures
    from .spec import parse_campaign_text
    from .store import Store

    store = Store(folder, read_only=True)
    try:
        meta = store.meta()
        c = parse_campaign_text(meta["campaign_text"], meta.get("campaign_path", "campaign"), check_keys=False)
        rows = store.rows()
        rates = pass_rates(store)
        fa = false_alarm_rate(store)
        runs = store.runs()
    finally:
        store.close()
    out = Path(folder) / "report"
    out.mkdir(parents=True, exist_ok=True)
    for r in rows:
        r["flat"] = flatten(json.loads(r["summary_json"])) if r["summary_json"] else {}
        r["inputs"] = json.loads(r["inputs_json"] or "{}")
        r["ok"] = bool(r["passed"]) and not r["error"]
    flown = [r for r in rows if not r["error"]]
    n, n_err = len(rows), sum(1 for r in rows if r["error"])
    h = [f"<!doctype html><html><head><meta charset='utf-8'><title>campaign {_esc(c.name)}</title>"
         f"<style>{_CSS}</style></head><body>",
         f"<h1>Campaign {_esc(c.name)}</h1>",
         f"<p>{_esc(c.description)}</p>" if c.description else "",
         f"<p>{n} of {c.trials} trials stored ({n_err} errors); file <code>{_esc(meta.get('campaign_path'))}</code>, "
         f"seed {c.seed}.</p>"]

    # pass rates
    h.append("<h2>Pass rates</h2><table><tr><th class=l>criterion</th><th class=l>expression</th>"
             "<th>passed</th><th>trials</th><th>rate</th><th>95 % CI (Wilson)</th></tr>")
    for name, k, nn, lo, hi in rates:
        expr = "every criterion, no error" if name == "all" else c.criteria[name].expr if name in c.criteria else ""
        h.append(f"<tr><td class=l>{_esc(name)}</td><td class=l><code>{_esc(expr)}</code></td><td>{k}</td>"
                 f"<td>{nn}</td><td>{100 * k / max(nn, 1):.1f} %</td><td>{100 * lo:.1f} - {100 * hi:.1f} %</td></tr>")
    h.append("</table>")
    if fa is not None:
        h.append(f"<p>Fault monitor false alarms: <b>{fa['false_alarms']}</b> in {fa['flight_hours']:.2f} flight "
                 f"hours: {fa['per_hour']:.3f} per hour, 95 % upper bound <b>{fa['upper95_per_hour']:.3f}</b> "
                 f"per hour (exact Poisson).</p>")

    # key figures
    figs = key_figures(c)
    numeric_figs = []
    for f, sign in figs:
        vals = [r["flat"].get(f) for r in flown]
        vals = [v for v in vals if isinstance(v, (int, float)) and not isinstance(v, bool)]
        if vals:
            numeric_figs.append((f, sign, vals))
    if numeric_figs:
        h.append("<h2>Key figures</h2><table><tr><th class=l>figure</th><th>trials</th><th>p50</th><th>p95</th>"
                 "<th>p99</th><th>max</th><th>min</th></tr>")
        for f, sign, vals in numeric_figs:
            p = percentiles(vals)
            h.append(f"<tr><td class=l>{_esc(f)}</td><td>{p['n']}</td><td>{p['p50']:.4g}</td><td>{p['p95']:.4g}</td>"
                     f"<td>{p['p99']:.4g}</td><td>{p['max']:.4g}</td><td>{p['min']:.4g}</td></tr>")
        h.append("</table>")
        for i, (f, sign, vals) in enumerate(numeric_figs):
            fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 3.2))
            a1.hist(vals, bins=min(40, max(5, len(vals) // 3)), color="#4a7")
            a1.set_xlabel(f)
            a1.set_ylabel("trials")
            s = sorted(vals)
            a2.step(s, [(j + 1) / len(s) for j in range(len(s))], where="post")
            for q in (0.5, 0.95, 0.99):
                a2.axhline(q, color="#999", lw=0.6)
            a2.set_xlabel(f)
            a2.set_ylabel("fraction of trials <= x")
            fig.tight_layout()
            name = f"figure_{i}.png"
            fig.savefig(out / name, dpi=80)
            plt.close(fig)
            h.append(f"<p><img src='{name}' alt='distribution of {_esc(f)}'></p>")

    # worst trials
    if numeric_figs:
        h.append("<h2>Worst trials</h2>")
        for f, sign, _vals in numeric_figs:
            ranked = sorted((r for r in flown if isinstance(r["flat"].get(f), (int, float))),
                            key=lambda r: -sign * r["flat"][f])[:5]
            h.append(f"<h3>{_esc(f)} ({'highest' if sign > 0 else 'lowest'})</h3><table><tr><th>trial</th>"
                     f"<th>{_esc(f)}</th><th>passed</th><th class=l>reproduce</th></tr>")
            for r in ranked:
                h.append(f"<tr><td>{r['trial']}</td><td>{r['flat'][f]:.4g}</td>"
                         f"<td class={'pass' if r['ok'] else 'fail'}>{r['ok']}</td>"
                         f"<td class=l><code>{_esc(r['command'])}</code></td></tr>")
            h.append("</table>")
    failed = [r for r in rows if not r["ok"]]
    if failed:
        h.append(f"<h2>Failed trials and errors ({len(failed)})</h2><table><tr><th>trial</th>"
                 f"<th class=l>failed criteria / error</th><th class=l>reproduce</th></tr>")
        for r in failed[:30]:
            crit = json.loads(r["criteria_json"] or "{}")
            why = r["error"].strip().splitlines()[-1] if r["error"] else \
                ", ".join(k for k, v in crit.items() if not v)
            h.append(f"<tr><td>{r['trial']}</td><td class=l>{_esc(why)}</td>"
                     f"<td class=l><code>{_esc(r['command'])}</code></td></tr>")
        h.append("</table>" + (f"<p>... and {len(failed) - 30} more.</p>" if len(failed) > 30 else ""))

    # inputs against pass/fail
    dispersed = c.dispersed()
    if dispersed and flown:
        h.append("<h2>Which inputs drive the failures</h2><p>Separation: the probability that a "
                 "failed trial's input exceeds a passed trial's (0.5: no effect; near 0 or 1: the input "
                 "drives the failures). Choices: the failure rate per value.</p><table><tr><th class=l>input"
                 "</th><th>separation</th><th class=l>failure rate by value</th></tr>")
        numeric_inputs = []
        for k in dispersed:
            vals = [(r["inputs"].get(k), r["ok"]) for r in flown]
            if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v, _ in vals):
                sep = auc([v for v, ok in vals if not ok], [v for v, ok in vals if ok])
                numeric_inputs.append(k)
                h.append(f"<tr><td class=l>{_esc(k)}</td><td>{'-' if sep is None else f'{sep:.2f}'}</td><td></td></tr>")
            else:
                by = {}
                for v, ok in vals:
                    by.setdefault(str(v), [0, 0])
                    by[str(v)][0] += (not ok)
                    by[str(v)][1] += 1
                txt = "; ".join(f"{_esc(v)}: {f}/{t}" for v, (f, t) in sorted(by.items()))
                h.append(f"<tr><td class=l>{_esc(k)}</td><td>-</td><td class=l>{txt}</td></tr>")
        h.append("</table>")
        if numeric_inputs:
            yfig = numeric_figs[0][0] if numeric_figs else None
            cols = min(3, len(numeric_inputs))
            rws = (len(numeric_inputs) + cols - 1) // cols
            fig, axes = plt.subplots(rws, cols, figsize=(4 * cols, 3 * rws), squeeze=False)
            for ax, k in zip(axes.flat, numeric_inputs):
                for ok, color, label in ((True, "#2a7", "passed"), (False, "#c22", "failed")):
                    pts = [(r["inputs"][k], r["flat"].get(yfig) if yfig else r["trial"]) for r in flown
                           if r["ok"] == ok]
                    pts = [(x, y) for x, y in pts if isinstance(y, (int, float))]
                    if pts:
                        ax.scatter([p[0] for p in pts], [p[1] for p in pts], s=10, c=color, label=label)
                ax.set_xlabel(k)
                ax.set_ylabel(yfig or "trial")
            for ax in list(axes.flat)[len(numeric_inputs):]:
                ax.axis("off")
            axes.flat[0].legend(fontsize=8)
            fig.tight_layout()
            fig.savefig(out / "inputs.png", dpi=80)
            plt.close(fig)
            h.append("<p><img src='inputs.png' alt='dispersed inputs against pass/fail'></p>")

    # throughput
    if runs:
        h.append("<h2>Throughput</h2><table><tr><th class=l>run</th><th>workers</th><th>threads</th>"
                 "<th>trials</th><th>wall s</th><th>sim s / wall s</th><th>trials / h</th>"
                 "<th>scheduling + storage</th><th>CPU share of a trial</th><th>sim s / CPU s</th>"
                 "<th class=l>cluster</th></tr>")
        for r in runs:
            wall = r["wall_s"] or 0.0
            over = 1.0 - r["trial_wall_s"] / (wall * r["threads"]) if wall > 0 and r["threads"] else None
            h.append(f"<tr><td class=l>{_esc(r['started'])}</td><td>{r['workers']}</td><td>{r['threads']}</td>"
                     f"<td>{r['trials']}</td><td>{wall:.1f}</td>"
                     f"<td>{(r['sim_s'] or 0) / wall if wall else 0:.1f}</td>"
                     f"<td>{r['trials'] / wall * 3600 if wall else 0:.0f}</td>"
                     f"<td>{'-' if over is None else f'{100 * over:.1f} %'}</td>"
                     f"<td>{_share(r.get('trial_cpu_s'), r['trial_wall_s'])}</td>"
                     f"<td>{_ratio(r['sim_s'], r.get('trial_cpu_s'))}</td>"
                     f"<td class=l>{_esc(r['scheduler'])}</td></tr>")
        h.append("</table><p>Scheduling + storage: the share of the workers' time (wall time x threads) "
                 "not spent inside trials. CPU share: the trials' CPU time over their wall time (below "
                 "100 % when other programs share the cores).</p>")
    h.append(_IMG_CHECK + "</body></html>")
    page = out / "index.html"
    page.write_text("\n".join(x for x in h if x))
    return page
