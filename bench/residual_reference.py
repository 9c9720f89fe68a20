#!/usr/bin/python3
"""How far a tracked frame's ICP residual strays from those of the frames tracked before it: the
measurement behind TrackingConfig::residual_ratio.

  /usr/bin/python3 bench/residual_reference.py SCAN SEQUENCE [SCAN SEQUENCE ...]

SCAN: an imufusion-scan output directory (its frames.csv); SEQUENCE: the sequence it scanned
(depth.txt, the depth PNGs, info.txt's depth_scale). For every frame ICP tracked in all six
directions (status tracking, pose source icp), q = (residual / weight_sum) / v, where v is the
frame's mean depth-noise variance over its depths in [0.3, 5] m under the scanner's default
DepthNoiseModel (sigma(z) = 0.0012 + 0.0019 (z - 0.4)^2 m), as the scanner computes it. Each
frame's q is divided by the median q of the --window frames tracked before it (once --warmup
are); the script prints, per scan and over all, the median q and the percentiles of that ratio:
the residual test's limit at TrackingConfig::residual_ratio r rejects a tracked frame whose
ratio exceeds r. Needs python3-numpy and python3-pil.
"""

import argparse
import csv
import os

import numpy as np

from sequence_depth import MAX_DEPTH, MIN_DEPTH, depth_frames, model_sigma, read_depth


def noise_variance(png, scale):
    """The frame's mean sigma(z)^2 (m^2) over its depths in [MIN_DEPTH, MAX_DEPTH]."""
    z = read_depth(png, scale)
    z = z[(z >= MIN_DEPTH) & (z <= MAX_DEPTH)]
    return float(np.mean(model_sigma(z) ** 2)) if z.size else 0.0


def ratios(scan, seq, window, warmup):
    """(q, ratio to the median of the frames before) of each tracked frame after the warm-up."""
    frames, scale = depth_frames(seq)
    index = {round(t, 4): png for t, png in frames}
    seen, out = [], []
    for row in csv.DictReader(open(os.path.join(scan, "frames.csv"))):
        if row["status"] != "tracking" or row["pose_source"] != "icp":
            continue
        if not row["residual"] or not row["weight_sum"] or float(row["weight_sum"]) <= 0:
            continue
        png = index.get(round(float(row["timestamp"]), 4))
        v = noise_variance(png, scale) if png else 0.0
        if v <= 0:
            continue
        q = float(row["residual"]) / float(row["weight_sum"]) / v
        if len(seen) >= warmup:
            out.append((q, q / float(np.median(seen[-window:]))))
        seen.append(q)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("pairs", nargs="+", help="SCAN SEQUENCE pairs")
    ap.add_argument("--window", type=int, default=15, help="TrackingConfig::pairing_window")
    ap.add_argument("--warmup", type=int, default=1, help="tracked frames before the first ratio")
    args = ap.parse_args()
    if len(args.pairs) % 2:
        ap.error("give SCAN SEQUENCE pairs")
    every = []
    fmt = "%-48s %5s %7s %6s %6s %6s %6s"
    print(fmt % ("scan", "n", "q med", "p50", "p99", "p99.9", "max"))
    for scan, seq in zip(args.pairs[0::2], args.pairs[1::2]):
        r = ratios(scan, seq, args.window, args.warmup)
        if not r:
            print("%-48s none tracked" % scan[-48:])
            continue
        q = np.array([x[0] for x in r])
        k = np.array([x[1] for x in r])
        every.append(k)
        print("%-48s %5d %7.3f %6.2f %6.2f %6.2f %6.2f" % (
            scan[-48:], len(k), np.median(q), np.median(k), np.percentile(k, 99),
            np.percentile(k, 99.9), k.max()))
    if every:
        k = np.concatenate(every)
        print("%-48s %5d %7s %6.2f %6.2f %6.2f %6.2f" % (
            "all", len(k), "", np.median(k), np.percentile(k, 99), np.percentile(k, 99.9), k.max()))


if __name__ == "__main__":
    main()
