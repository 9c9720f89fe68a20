#!/usr/bin/python3
"""The phone-ToF preset on the generator's phone ToF model: renders sequences with
imufusion-synth --sensor phone-tof, scans them with imufusion-scan --sensor phone-tof (with and
without the IMU, plus any --scan-args), scores them with imufusion-eval and prints one row per
scan and a summary per scene.

  /usr/bin/python3 bench/phone_tof.py --seeds 301-302 --scan-args "--voxel-size 0.02"
  /usr/bin/python3 bench/phone_tof.py --seeds 401-403 --no-imu-too

Renders are cached under --work (default /tmp/imufusion-phone-tof); runs go to WORK/runs/TAG.
Figures: ATE is imufusion-eval's RMSE after a rigid alignment (m); "lost" counts frames.csv rows
whose status is not tracking. Room and fast scans take --frames frames, wall scans at least 300
(the wall episode ends at 9.5 s).
"""

import argparse
import concurrent.futures
import csv
import json
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
WALL_FRAMES = 300


def parse_seeds(text):
    seeds = []
    for item in text.replace(",", " ").split():
        first, _, last = item.partition("-")
        seeds.extend(range(int(first), int(last or first) + 1))
    return seeds


def render(build, work, scene, seed, frames):
    out = work / "seq" / ("%s_%d_f%d" % (scene, seed, frames))
    if not (out / "info.txt").exists():
        subprocess.run([str(build / "tools/imufusion-synth"), "--scene", scene, "--seed",
                        str(seed), "--frames", str(frames), "--sensor", "phone-tof", "--out",
                        str(out), "--overwrite"], check=True, stdout=subprocess.DEVNULL)
    return out


def scan(build, sequence, out, extra):
    subprocess.run([str(build / "tools/imufusion-scan"), str(sequence), "--sensor", "phone-tof",
                    "--out", str(out), "--quiet"] + extra, check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    ate = json.loads(subprocess.run(
        [str(build / "tools/imufusion-eval"), str(sequence / "groundtruth.txt"),
         str(out / "trajectory.txt"), "--json"], check=True, capture_output=True,
        text=True).stdout)["ate_rmse"]
    with open(out / "frames.csv") as f:
        lost = sum(1 for row in csv.DictReader(f) if row["status"] != "tracking")
    return ate, lost


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--seeds", default="301-310")
    p.add_argument("--scenes", default="room fast wall")
    p.add_argument("--frames", type=int, default=150)
    p.add_argument("--scan-args", default="")
    p.add_argument("--tag", default="preset")
    p.add_argument("--no-imu-too", action="store_true", help="also scan each without the IMU")
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--build", type=Path, default=REPO / "build")
    p.add_argument("--work", type=Path, default=Path("/tmp/imufusion-phone-tof"))
    a = p.parse_args()
    jobs = []
    for scene in a.scenes.split():
        frames = max(a.frames, WALL_FRAMES) if scene == "wall" else a.frames
        for seed in parse_seeds(a.seeds):
            for imu in ([True, False] if a.no_imu_too else [True]):
                jobs.append((scene, seed, frames, imu))

    def run(job):
        scene, seed, frames, imu = job
        sequence = render(a.build, a.work, scene, seed, frames)
        out = a.work / "runs" / a.tag / ("%s_%d_%s" % (scene, seed, "imu" if imu else "noimu"))
        extra = a.scan_args.split() + ([] if imu else ["--no-imu"])
        return job, scan(a.build, sequence, out, extra)

    with concurrent.futures.ThreadPoolExecutor(a.jobs) as pool:
        results = list(pool.map(run, jobs))
    print("| scene | seed | IMU | ATE (mm) | frames lost |")
    print("| --- | --- | --- | --- | --- |")
    for (scene, seed, frames, imu), (ate, lost) in results:
        print("| %s | %d | %s | %.1f | %d of %d |" % (scene, seed, "yes" if imu else "no",
                                                    ate * 1e3, lost, frames))
    print()
    print("| scene | IMU | ATE median / max (mm) | frames lost, total |")
    print("| --- | --- | --- | --- |")
    for scene in a.scenes.split():
        for imu in ([True, False] if a.no_imu_too else [True]):
            rows = [r for j, r in results if j[0] == scene and j[3] == imu]
            ates = sorted(r[0] * 1e3 for r in rows)
            print("| %s | %s | %.1f / %.1f | %d |" % (scene, "yes" if imu else "no",
                                                      ates[len(ates) // 2], ates[-1],
                                                      sum(r[1] for r in rows)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
