#!/usr/bin/python3
"""How a sequence's depth noise is structured, against the scanner's depth-noise model: the
measurement behind "how the generators' depth differs from the real sensor's" in bench/README.md.

  /usr/bin/python3 bench/depth_noise_structure.py SEQUENCE [SEQUENCE ...] [--frames N]

For --frames depth images spread over each sequence (depth.txt, info.txt's depth_scale), along
image rows over pixel triples with depth in [0.3, 5] m:
  - white / model: the variance of the second difference z(u+1) - 2 z(u) + z(u-1) over 6 (what
    independent per-pixel noise of that variance gives; the robust MAD estimate, so that depth
    edges do not count), divided by the scanner's default DepthNoiseModel variance at each
    pixel, sigma(z) = 0.0012 + 0.0019 (z - 0.4)^2 m. About 1 for independent noise at the
    model's level, about 0 for depth that is flat over neighbouring pixels;
  - flat share: the share of triples whose second difference is exactly zero (quantized depth
    steps, noise correlated over neighbouring pixels).
Medians over the frames. Needs python3-numpy and python3-pil.
"""

import argparse

import numpy as np

from sequence_depth import MAX_DEPTH, MIN_DEPTH, depth_frames, model_sigma, read_depth


def frame_figures(png, scale):
    """(white / model, flat share) of one depth image; None without valid depth."""
    z = read_depth(png, scale)
    ok = (z >= MIN_DEPTH) & (z <= MAX_DEPTH)
    d2 = z[:, 2:] - 2 * z[:, 1:-1] + z[:, :-2]
    valid = ok[:, 2:] & ok[:, 1:-1] & ok[:, :-2]
    if not valid.any():
        return None
    zc, e = z[:, 1:-1][valid], d2[valid]
    u = e / model_sigma(zc)
    mad = 1.4826 * np.median(np.abs(u - np.median(u)))
    return mad * mad / 6.0, float(np.mean(e == 0))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("sequences", nargs="+")
    ap.add_argument("--frames", type=int, default=12, help="depth images per sequence")
    args = ap.parse_args()
    print("%-48s %13s %10s" % ("sequence", "white / model", "flat share"))
    for seq in args.sequences:
        frames, scale = depth_frames(seq)
        files = [png for _, png in frames]
        step = max(1, len(files) // args.frames)
        figures = [f for f in (frame_figures(p, scale) for p in files[::step][:args.frames]) if f]
        if not figures:
            print("%-48s no valid depth" % seq[-48:])
            continue
        print("%-48s %13.3f %10.3f" % (seq[-48:], np.median([f[0] for f in figures]),
                                       np.median([f[1] for f in figures])))


if __name__ == "__main__":
    main()
