"""How well LSL timestamps follow the unit's sample clock (``docs/lsl.md`` quotes this).

    python benchmarks/bench_lsl_clock.py              # synthetic link + 20 s live over a pty
    python benchmarks/bench_lsl_clock.py --live-s 60  # a longer live run

1. Synthetic (``gaitmon.dsp.sample_clock`` alone, against the closed form): a unit whose crystal is
   off by -50, 0 or +50 ppm, 120 s, frames delivered in bursts of 1-20 with a 3 ms floor
   delay plus exponential jitter (mean 4 ms), a one-second stall now and then, 1 % of frames
   lost and a 3 s cut. It prints the error of each sample's timestamp, as stamped when its
   block arrived, against the truth (the sample's making time plus the floor delay): the
   largest after the first 5 s, the 99th percentile, and the same for the receive times.
2. Live (the engine, the simulated unit over a real pty in real time, the outlets and a pylsl
   inlet in this process): the share of samples received, and the jitter of the received
   timestamps: their residual against a straight line through (frame counter, timestamp),
   after the first ``--settle-s``, and for comparison that of the receive times.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))


def synthetic() -> None:
    from test_sample_clock import FLOOR_S, FS, synthetic_link

    from gaitmon.dsp.sample_clock import SampleClock

    print("synthetic link, 120 s: error of the timestamps against the truth (ms)")
    print("| crystal | max after 5 s | p99 after 5 s | receive times: p99 | max | fitted ppm |")
    print("|---|---|---|---|---|---|")
    for ppm, seed in ((-50.0, 2), (0.0, 3), (50.0, 1)):
        blocks, period = synthetic_link(ppm, 120.0, seed)
        clock = SampleClock(FS)
        ks, errs, recv = [], [], []
        for k, h in blocks:
            clock.update(k, h)
            truth = 1000.0 + FLOOR_S + k * period
            ks.append(k)
            errs.append(clock.map(k) - truth)
            recv.append(h - truth)
        k = np.concatenate(ks)
        e = np.abs(np.concatenate(errs))[k >= 5 * FS] * 1e3
        r = np.abs(np.concatenate(recv)) * 1e3
        fitted = clock.rate_error_ppm
        print(f"| {ppm:+.0f} ppm | {e.max():.3f} | {np.percentile(e, 99):.3f} | "
              f"{np.percentile(r, 99):.1f} | {r.max():.0f} | {fitted:+.1f} |")  # fmt: skip


def live(seconds: float, settle_s: float) -> None:
    import pylsl

    from gaitmon.engine import Engine
    from gaitmon.io.device import Device
    from gaitmon.io.sim import GaitConfig, SimulatedUnit
    from gaitmon.io.sim.pty import PtySimulator
    from gaitmon.io.transport import SerialTransport
    from gaitmon.lsl import layout
    from gaitmon.lsl.outlets import LslOutlets

    unit_id = f"bench{int(time.time())}"
    unit = SimulatedUnit(GaitConfig(seed=1, standing_s=2.0), speed=1.0)
    got_ts: list[np.ndarray] = []
    got_raw: list[np.ndarray] = []
    host: list[np.ndarray] = []
    with PtySimulator(unit) as sim:
        eng = Engine(Device(SerialTransport(str(sim.link_path))), "raw", transport_label="pty")
        inlets = {}

        def before() -> None:
            outlets = LslOutlets.attach(eng, unit=unit_id)
            eng.add_listener(lambda out: host.append(np.asarray(out.host_time_s)))
            inlets["o"] = outlets
            found = pylsl.resolve_byprop("source_id", layout.source_id(unit_id, "raw"), 1, 10)
            inlets["raw"] = pylsl.StreamInlet(found[0], max_buflen=360, recover=False)
            inlets["raw"].open_stream(timeout=10)

        eng.start(before_stream=before)
        t_end = time.monotonic() + seconds
        while time.monotonic() < t_end:
            d, ts = inlets["raw"].pull_chunk(timeout=0.1)
            if ts:
                got_raw.append(np.asarray(d))
                got_ts.append(np.asarray(ts))
        eng.stop()
        pushed = inlets["o"].samples_pushed
        t_end = time.monotonic() + 3
        while sum(len(t) for t in got_ts) < pushed and time.monotonic() < t_end:
            d, ts = inlets["raw"].pull_chunk(timeout=0.1)
            if ts:
                got_raw.append(np.asarray(d))
                got_ts.append(np.asarray(ts))
        inlets["o"].detach()
    ts = np.concatenate(got_ts)
    seq = np.concatenate(got_raw)[:, 0].astype(np.float64)
    h = np.concatenate(host)[: len(ts)]
    late = seq >= seq[0] + settle_s * 100
    print(f"\nlive over a pty, {seconds:g} s in real time: received {len(ts)} of {pushed} "
          f"samples ({100 * len(ts) / pushed:.2f} %)")  # fmt: skip
    for what, t in (("LSL timestamps", ts), ("receive times", h)):
        coef = np.polyfit(seq[late], t[late], 1)
        res = np.abs(t[late] - np.polyval(coef, seq[late])) * 1e3
        print(f"  {what}: residual against the sample clock after {settle_s:g} s: "
              f"max {res.max():.3f} ms, p99 {np.percentile(res, 99):.3f} ms")  # fmt: skip
    coef = np.polyfit(seq, ts, 1)
    res = np.abs(ts - np.polyval(coef, seq)) * 1e3
    print(f"  LSL timestamps from the first sample: max {res.max():.3f} ms")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else "")
    ap.add_argument("--live-s", type=float, default=20.0)
    ap.add_argument("--settle-s", type=float, default=2.0)
    args = ap.parse_args()
    synthetic()
    if args.live_s > 0:
        live(args.live_s, args.settle_s)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
