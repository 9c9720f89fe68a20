#!/usr/bin/python3
"""The metric scale of a trajectory measured by the accelerometer: k in a_traj = k * a_imu.

The trajectory's positions (TUM format, camera to world) are resampled at 100 Hz, smoothed by a
Gaussian of --smooth seconds and differentiated twice; the accelerometer's specific force (imu.txt,
IMU frame) is turned into the camera frame (imu_to_camera.txt) and into the world by the
trajectory's own orientations, smoothed the same way. Both are high-passed (minus a Gaussian
of --high-pass seconds), which removes gravity and the accelerometer bias while the camera turns
little. k is the least-squares ratio over the whole overlap and over --window second windows.
A trajectory whose motion the depth sees too long has k > 1; the ground truth gives about 1.

  /usr/bin/python3 bench/accel_scale.py ../shared/datasets/tum_fr1_xyz scan/trajectory.txt
"""

import argparse
from pathlib import Path

import numpy as np
from scipy.ndimage import gaussian_filter1d
from scipy.spatial.transform import Rotation, Slerp

RATE = 100.0  # Hz of the common time grid


def rows(path):
    return np.array([[float(x) for x in line.split()] for line in open(path)
                     if line.strip() and not line.startswith("#")])


def scale(traj, imu, R_camera_imu, smooth, high_pass, window):
    t, P, R = traj[:, 0], traj[:, 1:4], Rotation.from_quat(traj[:, 4:8])
    begin, end = max(t[0], imu[0, 0]) + 1, min(t[-1], imu[-1, 0]) - 1
    grid = np.arange(begin, end, 1 / RATE)
    pos = np.stack([np.interp(grid, t, P[:, i]) for i in range(3)], 1)
    force = np.stack([np.interp(grid, imu[:, 0], imu[:, 4 + i]) for i in range(3)], 1)
    force_world = Slerp(t, R)(grid).apply(R_camera_imu.apply(force))
    sigma = smooth * RATE
    acc = np.gradient(np.gradient(gaussian_filter1d(pos, sigma, axis=0), 1 / RATE, axis=0),
                      1 / RATE, axis=0)
    force_world = gaussian_filter1d(force_world, sigma, axis=0)

    def high(x):
        return x - gaussian_filter1d(x, high_pass * RATE, axis=0)

    a, f = high(acc), high(force_world)
    k = (a * f).sum() / (f * f).sum()
    n = int(window * RATE)
    windows = [(a[i:i + n] * f[i:i + n]).sum() / (f[i:i + n] ** 2).sum()
               for i in range(0, len(grid) - n + 1, n)]
    return k, windows


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("sequence", type=Path, help="a sequence with imu.txt (and groundtruth.txt)")
    ap.add_argument("trajectories", nargs="*", type=Path, help="TUM trajectories (default: none)")
    ap.add_argument("--smooth", type=float, default=0.1, help="s (default 0.1)")
    ap.add_argument("--high-pass", type=float, default=1.0, help="s (default 1)")
    ap.add_argument("--window", type=float, default=5.0, help="s (default 5)")
    args = ap.parse_args()
    imu = rows(args.sequence / "imu.txt")
    mounting = args.sequence / "imu_to_camera.txt"
    R_camera_imu = Rotation.from_quat(rows(mounting)[0, :4]) if mounting.exists() else Rotation.identity()
    named = [("ground truth", args.sequence / "groundtruth.txt")] if (args.sequence / "groundtruth.txt").exists() else []
    for name, path in named + [(str(p), p) for p in args.trajectories]:
        k, windows = scale(rows(path), imu, R_camera_imu, args.smooth, args.high_pass, args.window)
        print("%s: scale %.3f; per %g s: %s" % (name, k, args.window, " ".join("%.3f" % w for w in windows)))


if __name__ == "__main__":
    main()
