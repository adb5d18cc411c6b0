"""A bilateral recording against the simulator's truth: the issue-17 goals, measured.

Two engines record a simulated pair served on two pseudo-terminals (the real pyserial path),
faster than real time, into one session (``EnginePair``: two parts, combined with the clock
fits). The detected events are mapped to common time by the file's clock fits and compared with
the truth. The simulator paces both units on ``time.monotonic`` from one epoch, common time
running ``speed`` times as fast, so host time H is the simulator's common time
``(H - epoch) * speed``; one delivery delay shared by both legs is removed (the median error).

Printed: heel-strike alignment between the units (p95 |error| after that one constant, and the
difference of the two legs' median errors), the fitted relative drift against the configured
one, the double-support error (median |error| per heel strike), and the step-time symmetry ratio
against the truth's.

    python benchmarks/bilateral_record.py [--seconds 600] [--speed 10] [--loss-pct 2]
        [--asymmetry hemiparetic]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from gaitmon.analysis import analyse_bilateral
from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.engine import Engine
from gaitmon.engine.pair import EnginePair
from gaitmon.finish.bilateral import open_bilateral
from gaitmon.io.device import Device
from gaitmon.io.ports import make_transport
from gaitmon.io.sim.bilateral import (
    DEFAULT_LEFT,
    DEFAULT_RIGHT,
    BilateralConfig,
    BilateralPty,
    BilateralSim,
)
from gaitmon.io.sim.faults import FaultConfig


def _nearest(t: np.ndarray, ref: np.ndarray) -> np.ndarray:
    j = np.clip(np.searchsorted(ref, t), 1, len(ref) - 1)
    return np.where(np.abs(t - ref[j - 1]) < np.abs(t - ref[j]), j - 1, j)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=600.0)
    ap.add_argument("--speed", type=float, default=10.0)
    ap.add_argument("--loss-pct", type=float, default=2.0)
    ap.add_argument("--asymmetry", default="none", choices=("none", "hemiparetic"))
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    specs = [
        type(s)(s.serial, s.clock, FaultConfig(seed=20 + i, loss_pct=args.loss_pct))
        for i, s in enumerate((DEFAULT_LEFT, DEFAULT_RIGHT))
    ]
    config = BilateralConfig(speed=args.speed, asymmetry=args.asymmetry, seed=args.seed,
                             left=specs[0], right=specs[1])  # fmt: skip
    sim = BilateralSim(config)
    with tempfile.TemporaryDirectory() as tmp, BilateralPty(sim) as pty:
        out = Path(tmp) / "both.h5"
        engines = [Engine(Device(make_transport(str(p))), "raw", PipelineConfig())
                   for p in pty.link_paths]  # fmt: skip
        pair = EnginePair(*engines)
        t0 = time.perf_counter()
        pair.start(out)
        while min(pair.recorded_s(s) for s in "LR") < args.seconds:
            time.sleep(0.1)
        pair.stop()
        pair.finish()
        took = time.perf_counter() - t0
        truth = sim.truth()
        with open_bilateral(out) as b:
            an = analyse_bilateral(b)
            err = {}
            for side in "LR":
                u = b.unit(side)
                t = u.read("timeline/t_s")
                c = (b.sync[side].host_at(t[u.heel_strike_idx]) - sim.epoch) * args.speed
                ref = truth.side(side).heel_strike_s
                e = c - ref[_nearest(c, ref)]
                err[side] = e[np.abs(e) < 0.2]
            both = np.concatenate(list(err.values()))
            offset = float(np.median(both))
            ds = []
            for side in "LR":
                mine, tru = an.gait.side(side), truth.gait.side(side)
                host = b.host_t0_s + mine.heel_strike_s * b.host_s_per_common_s
                j = _nearest((host - sim.epoch) * args.speed, tru.heel_strike_s)
                for m in ("initial_double_support_s", "terminal_double_support_s"):
                    d = getattr(mine, m) - getattr(tru, m)[j]
                    ds.append(d[np.isfinite(d)])
            rel = (b.sync["R"].mean_slope / b.sync["L"].mean_slope - 1.0) * 1e6
            rates = [config.unit_spec(s).clock.rate for s in "LR"]
            lost = {s: sum(g.n_lost for g in b.unit(s).gaps) for s in "LR"}
            p95 = {s: b.sync[s].residual_p95_ms for s in "LR"}
    dsa = np.abs(np.concatenate(ds))
    print(f"{args.seconds:g} s per unit at {args.speed:g}x ({took:.0f} s), {args.loss_pct:g} % "
          f"loss per link (frames lost L {lost['L']}, R {lost['R']}), "
          f"{args.asymmetry}")  # fmt: skip
    print(f"heel-strike alignment p95 |error|  {np.percentile(np.abs(both - offset), 95) * 1e3:.1f}"
          f" ms (goal <= 10); legs' median errors differ by "
          f"{abs(np.median(err['L']) - np.median(err['R'])) * 1e3:.1f} ms; shared delivery delay "
          f"{offset * 1e3:.1f} ms; {len(both)} heel strikes")  # fmt: skip
    print(f"relative drift R vs L              {rel:+.1f} ppm fitted, "
          f"{(rates[0] / rates[1] - 1) * 1e6:+.1f} configured; fit residual p95 L {p95['L']:.1f},"
          f" R {p95['R']:.1f} host ms")  # fmt: skip
    print(f"double-support error median        {np.median(dsa) * 1e3:.1f} ms (goal <= 10), p95 "
          f"{np.percentile(dsa, 95) * 1e3:.1f} ms, {len(dsa)} intervals")  # fmt: skip
    sr, sr_true = an.gait.symmetry_of("step_s").ratio, truth.gait.symmetry_of("step_s").ratio
    print(f"step-time symmetry ratio           {sr:.4f} (truth {sr_true:.4f}; goal within 0.02)")


if __name__ == "__main__":
    main()
