"""``python -m tools.samecheck BEFORE AFTER``: did a speed change change a flight?

BEFORE and AFTER are run folders (``sitl run --log-dir``) of the same flight (vehicle,
mission, scenario, seed) flown by two trees, or directories holding several such run
folders under the same names. For each pair: whether the flight logs (``flight.npz``)
are bit-identical, and if not, the largest relative difference of the summary's
figures (``summary.json``: every number, nested, timing figures left out), which must
stay within ``--tol`` (default 1 %; a compiled kernel may sum in another order).
Exit status 1 when a pair fails.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

#: figures that measure the machine, not the flight
TIMING_KEYS = frozenset({"realtime_factor", "wall_s", "wall_time_s", "run_dir", "log_dir"})


def _numbers(obj, prefix: str = ""):
    if isinstance(obj, bool):
        yield prefix, float(obj)
    elif isinstance(obj, (int, float)):
        yield prefix, float(obj)
    elif isinstance(obj, dict):
        for k, v in obj.items():
            if k not in TIMING_KEYS:
                yield from _numbers(v, f"{prefix}.{k}" if prefix else str(k))
    elif isinstance(obj, (list, tuple)):
        for i, v in enumerate(obj):
            yield from _numbers(v, f"{prefix}[{i}]")


def logs_identical(a: Path, b: Path) -> bool:
    with np.load(a / "flight.npz") as fa, np.load(b / "flight.npz") as fb:
        if sorted(fa.files) != sorted(fb.files):
            return False
        return all(fa[k].shape == fb[k].shape and fa[k].dtype == fb[k].dtype
                   and fa[k].tobytes() == fb[k].tobytes() for k in fa.files)


def summary_diff(a: Path, b: Path, floor: float = 1e-3) -> tuple[float, str]:
    """Largest |after - before| / max(|before|, floor) over the summaries' numbers, and
    its key (a key present in one summary only counts as infinitely different)."""
    sa = dict(_numbers(json.loads((a / "summary.json").read_text())))
    sb = dict(_numbers(json.loads((b / "summary.json").read_text())))
    worst, key = 0.0, ""
    for k in sorted(set(sa) | set(sb)):
        if k not in sa or k not in sb:
            return math.inf, k
        x, y = sa[k], sb[k]
        if x == y or (math.isnan(x) and math.isnan(y)):
            continue
        d = abs(y - x) / max(abs(x), floor)
        if d > worst:
            worst, key = d, k
    return worst, key


def compare(before: Path, after: Path, tol: float = 0.01, out=print) -> bool:
    pairs = ([(before, after)] if (before / "summary.json").exists()
             else [(d, after / d.name) for d in sorted(before.iterdir()) if (d / "summary.json").exists()])
    ok = True
    for a, b in pairs:
        if not (b / "summary.json").exists():
            out(f"{a.name}: missing in {after}")
            ok = False
            continue
        same = logs_identical(a, b)
        d, k = summary_diff(a, b)
        good = same or d <= tol
        ok &= good
        out(f"{a.name}: flight log {'bit-identical' if same else 'differs'}; summary "
            f"{'identical' if d == 0 else f'largest relative difference {d:.2e} ({k})'}"
            f"{'' if good else '  FAIL'}")
    return ok


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("before", type=Path)
    ap.add_argument("after", type=Path)
    ap.add_argument("--tol", type=float, default=0.01)
    args = ap.parse_args(argv)
    return 0 if compare(args.before, args.after, args.tol) else 1


if __name__ == "__main__":
    sys.exit(main())
