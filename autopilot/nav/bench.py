"""Cost of the navigation filters per 100 Hz step: ``python -m autopilot.nav.bench``.

Runs a simulated manoeuvring flight (:mod:`.simulate`) through a filter several times
and reports the best-of-N mean cost of the predict and of everything else in
``update()`` (measurement assembly, gating, fusion, records, NavState), per step.
Best-of-N because the machine may be shared; the mean is over all steps, so the
update figure is the typical mix (aux sensors at ``--aux-hz``, GPS at 5 Hz).
"""
from __future__ import annotations

import argparse
import math
import time

import numpy as np

from .ekf import InsGpsEkf
from .simulate import SimConfig, simulate_flight


def bench(cls=InsGpsEkf, aux_hz: float = 50.0, seconds: float = 30.0, repeats: int = 5,
          seed: int = 3) -> dict[str, float]:
    """{'predict_us', 'update_us', 'step_us'}: best-of-``repeats`` means per step."""
    cfg = SimConfig(mag_rate_hz=aux_hz, baro_rate_hz=aux_hz, airspeed_rate_hz=aux_hz)
    sim = simulate_flight(np.random.default_rng(seed), cfg, segments=((seconds + 5.0, 20.0, 1.0),))
    frames = list(sim.frames())
    params = {"EK_MAG_DEC": math.radians(cfg.mag_declination_deg), "EK_MAG_AUTODEC": 0}
    best = None
    for _ in range(repeats):
        f = cls(params, "plane", cfg.origin())
        for fr in frames[:500]:                      # align and settle, not timed
            f.update(fr)
        acc = [0.0]
        inner = f._predict
        clock = time.perf_counter

        def timed_predict(dt, f1, w1, t, inner=inner, acc=acc, clock=clock):
            t0 = clock()
            inner(dt, f1, w1, t)
            acc[0] += clock() - t0

        f._predict = timed_predict
        t0 = clock()
        for fr in frames[500:]:
            f.update(fr)
        total = clock() - t0
        n = len(frames) - 500
        r = {"predict_us": acc[0] / n * 1e6, "step_us": total / n * 1e6}
        r["update_us"] = r["step_us"] - r["predict_us"]
        if best is None or r["step_us"] < best["step_us"]:
            best = r
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--aux-hz", type=float, nargs="+", default=[50.0, 100.0])
    ap.add_argument("--ukf", action="store_true", help="also time the UKF (slow)")
    ap.add_argument("--repeats", type=int, default=5, help="best of this many runs (shared machines)")
    args = ap.parse_args()
    classes = [InsGpsEkf]
    if args.ukf:
        from .ukf import InsGpsUkf
        classes.append(InsGpsUkf)
    for cls in classes:
        for hz in args.aux_hz:
            ekf = cls is InsGpsEkf
            r = bench(cls, hz, seconds=30.0 if ekf else 8.0,
                      repeats=args.repeats if ekf else max(2, args.repeats // 3))
            print(f"{cls.__name__:10s} aux {hz:5.0f} Hz: predict {r['predict_us']:6.1f} us, "
                  f"update {r['update_us']:6.1f} us, step {r['step_us']:6.1f} us")


if __name__ == "__main__":
    main()
