"""The bilateral simulator against its own truth, through the real decoder and pipeline.

Both units of a simulated pair stream RAW frames (with their own link loss) as fast as they
are read; each unit's samples go through the single-unit pipeline (``gaitmon.dsp.pipeline``,
told the lost frames); the detected heel strikes and toe offs are mapped to common time with
the units' KNOWN clock parameters (offset, ppm: no estimation, that is the engine's job) and
compared with the truth. Printed per side: event timing error (median, p95 |error|, max
|error|), the drift fitted from heel strikes against the counter, and the symmetry table from
the detected events beside the truth's.

    python benchmarks/bilateral_sim.py [--seconds 300] [--asymmetry hemiparetic] [--loss-pct 2]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from gaitmon.dsp.bilateral import bilateral_gait
from gaitmon.dsp.pipeline import Pipeline, PipelineConfig
from gaitmon.io import protocol as P
from gaitmon.io.decoder import FrameDecoder
from gaitmon.io.sim.bilateral import DEFAULT_LEFT, DEFAULT_RIGHT, BilateralConfig, BilateralSim
from gaitmon.io.sim.faults import FaultConfig


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=300.0)
    ap.add_argument("--asymmetry", default="none", choices=("none", "hemiparetic"))
    ap.add_argument("--affected", default="L", choices=("L", "R"))
    ap.add_argument("--loss-pct", type=float, default=0.0)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    specs = [
        type(s)(s.serial, s.clock, FaultConfig(seed=10 + i, loss_pct=args.loss_pct))
        for i, s in enumerate((DEFAULT_LEFT, DEFAULT_RIGHT))
    ]
    cfg = BilateralConfig(
        speed=math.inf,
        seed=args.seed,
        asymmetry=args.asymmetry,
        affected=args.affected,
        left=specs[0],
        right=specs[1],
    )
    t0 = time.perf_counter()
    sim = BilateralSim(cfg, afap_block=5000)
    n = int(args.seconds * 100)
    events = {}
    for side, unit in zip("LR", sim.units, strict=True):
        dec = FrameDecoder()
        unit.write(P.encode_command(P.Command.START_STREAM))
        frames = []
        while unit.samples_produced < n:
            frames += dec.feed(unit.read())
        raw = [f for f in frames if isinstance(f, P.RawFrame)]
        seq = np.array([f.seq for f in raw], dtype=np.int64)  # no wrap below 655 s
        sample = seq - 1  # the ACK took sequence number 0; then one frame per tick
        lost = np.r_[0, np.diff(sample) - 1]
        pb = Pipeline(PipelineConfig()).process(np.array([f.adc for f in raw]), lost)
        clock = cfg.unit_spec(side).clock
        hs, to = sample[pb.heel_strike_idx], sample[pb.toe_off_idx]
        events[side] = (clock.offset_s + hs / (100.0 * clock.rate),
                        clock.offset_s + to / (100.0 * clock.rate), hs)  # fmt: skip
        print(f"{side}: {len(raw)} frames, {dec.stats.frames_lost} lost, "
              f"clock {clock.offset_s:g} s {clock.ppm:+g} ppm")  # fmt: skip
    truth = sim.truth(0.0, args.seconds + 10.0)
    print(
        f"simulated and processed {args.seconds:g} s per unit in {time.perf_counter() - t0:.1f} s"
    )
    print("event error vs truth, ms (detected - true): median, p95 |err|, max |err|")
    for side in "LR":
        st = truth.side(side)
        got_hs, got_to, hs_idx = events[side]
        for name, true_s, got in (("heel strike", st.heel_strike_s, got_hs),
                                  ("toe off", st.toe_off_s, got_to)):  # fmt: skip
            k = np.clip(np.searchsorted(true_s, got), 1, len(true_s) - 1)
            k = np.where(np.abs(true_s[k] - got) < np.abs(true_s[k - 1] - got), k, k - 1)
            err = (got - true_s[k]) * 1e3
            print(f"  {side} {name:<11} n={len(err):4d}  {np.median(err):+5.1f}  "
                  f"{np.percentile(np.abs(err), 95):4.1f}  {np.abs(err).max():4.1f}")  # fmt: skip
            if name == "heel strike":
                slope, icpt = np.polyfit(hs_idx.astype(float), true_s[k], 1)
                fit_ppm = (1.0 / (slope * 100.0) - 1.0) * 1e6
                print(f"  {side} drift fitted {fit_ppm:+.1f} ppm (configured "
                      f"{st.clock.ppm:+g}), offset {icpt * 1e3:.1f} ms "
                      f"(configured {st.clock.offset_s * 1e3:.1f})")  # fmt: skip
    g = bilateral_gait(*events["L"][:2], *events["R"][:2], max_stride_s=2.5)
    print("symmetry (L/R)            measured: ratio   SI %   truth: ratio   SI %")
    for row, true in zip(g.symmetry, truth.gait.symmetry, strict=True):
        print(f"  {row.label:<24} {row.ratio:14.4f} {row.index_pct:6.2f} "
              f"{true.ratio:14.4f} {true.index_pct:6.2f}")  # fmt: skip
    print(f"cadence measured {g.cadence_steps_min:.1f} steps/min, "
          f"truth {truth.gait.cadence_steps_min:.1f}")  # fmt: skip


if __name__ == "__main__":
    main()
