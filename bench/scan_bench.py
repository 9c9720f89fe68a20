#!/usr/bin/python3
"""Speed of a whole scan against the Open3D peer, on the same frames, back to back.

For each sequence it runs imufusion-scan and then ../shared/tools/o3d_slam.py (tensor SLAM,
--raycast-offset-fix) on the first --frames frames at the same voxel size, --repeat times in
alternation, and prints per run: mean and median ms per frame, fps, ATE and frames not tracked;
for ours the share of each stage (summary.json stage_ms) and the slowest kernels (GPU ms and
dispatches per frame, from the timestamp queries); then the ratio of the peer's mean frame time
to ours (3 or more: a third of the peer's time or less).

  /usr/bin/python3 bench/scan_bench.py                                    # TUM + both generators
  /usr/bin/python3 bench/scan_bench.py --sequence ../shared/datasets/tum_fr1_xyz --repeat 2
  /usr/bin/python3 bench/scan_bench.py --synth room:1 --render fast:801 --frames 300 --no-peer

Sequences: --sequence DIR (a recorded sequence with groundtruth.txt), --synth SCENE:SEED (the
project's imufusion-synth), --render SCENE:SEED (the independent renderer
../shared/tools/render_sequence.py). Default: TUM fr1_xyz, --synth room:1 and --render room:1.
Generated sequences are cached under --work. Needs build/tools/imufusion-scan and, for the peer
and the renderer, ../shared with Debian's python3-open3d.
"""

import argparse
import json
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
STAGES = ["preprocess", "icp", "integrate", "raycast", "relocalize", "retrack"]


def parse_args():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sequence", action="append", default=[], type=Path, help="a recorded sequence")
    ap.add_argument("--synth", action="append", default=[], help="SCENE:SEED of imufusion-synth")
    ap.add_argument("--render", action="append", default=[], help="SCENE:SEED of render_sequence.py")
    ap.add_argument("--frames", type=int, default=100, help="frames scanned (default 100)")
    ap.add_argument("--voxel", type=float, default=0.015, help="voxel size (m, default 0.015)")
    ap.add_argument("--repeat", type=int, default=1, help="runs of each, alternating (default 1)")
    ap.add_argument("--no-peer", action="store_true", help="only imufusion-scan")
    ap.add_argument("--scan-args", default="", help='extra imufusion-scan options, e.g. "--no-imu"')
    ap.add_argument("--shared", type=Path, default=REPO.parent / "shared", help="default ../shared")
    ap.add_argument("--build", type=Path, default=REPO / "build", help="default build")
    ap.add_argument("--work", type=Path, default=Path("/tmp/imufusion-scan-bench"))
    ap.add_argument("--json", type=Path, help="also write every figure to this file")
    args = ap.parse_args()
    if args.frames < 2 or args.repeat < 1:
        ap.error("--frames must be at least 2 and --repeat at least 1")
    if not (args.sequence or args.synth or args.render):
        args.sequence = [args.shared / "datasets" / "tum_fr1_xyz"]
        args.synth, args.render = ["room:1"], ["room:1"]
    return args


def fail(message):
    sys.exit("scan_bench.py: error: " + message)


def run(cmd, log):
    """Runs cmd with its output in the file log; fails naming the log on a non-zero exit."""
    with open(log, "w") as out:
        code = subprocess.call([str(c) for c in cmd], stdout=out, stderr=subprocess.STDOUT, cwd=REPO)
    if code != 0:
        fail("%s exited %d (log %s): %s" % (Path(str(cmd[0])).name, code, log,
                                            " | ".join(Path(log).read_text().splitlines()[-3:])))


def scene_seed(text):
    scene, _, seed = text.partition(":")
    if scene not in ("room", "wall", "fast") or not seed.isdigit():
        fail("expected SCENE:SEED with SCENE room, wall or fast: %r" % text)
    return scene, int(seed)


def generated(args, kind, text):
    """The cached sequence of imufusion-synth ('synth') or render_sequence.py ('render')."""
    scene, seed = scene_seed(text)
    frames = max(args.frames, 240 if scene == "wall" else 0)
    out = args.work / "sequences" / ("%s_%s_s%d_f%d" % (kind, scene, seed, frames))
    if (out / "depth.txt").exists():
        return out
    tmp = out.with_name(out.name + ".tmp")
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.parent.mkdir(parents=True, exist_ok=True)
    if kind == "synth":
        cmd = [args.build / "tools" / "imufusion-synth", "--scene", scene, "--seed", seed,
               "--frames", frames, "--out", tmp]
    else:
        cmd = ["/usr/bin/python3", args.shared / "tools" / "render_sequence.py", "--scene", scene,
               "--seed", seed, "--frames", frames, "--out", tmp]
    run(cmd, str(tmp) + ".log")
    tmp.rename(out)
    return out


def ate(args, sequence, trajectory):
    """eval_traj.py's ATE RMSE (m) after an SE(3) alignment, or None without ground truth."""
    gt = sequence / "groundtruth.txt"
    tool = args.shared / "tools" / "eval_traj.py"
    if not gt.exists() or not tool.exists():
        return None
    text = subprocess.run(["/usr/bin/python3", str(tool), str(gt), str(trajectory)],
                          capture_output=True, text=True).stdout
    try:
        return json.loads(text)["ate_rmse"]
    except (ValueError, KeyError):
        return None


def ours(args, sequence, out):
    shutil.rmtree(out, ignore_errors=True)
    cmd = [args.build / "tools" / "imufusion-scan", sequence, "--out", out, "--quiet",
           "--frames", args.frames, "--voxel-size", args.voxel] + args.scan_args.split()
    run(cmd, str(out) + ".log")
    s = json.loads((out / "summary.json").read_text())
    frame_ms = [float(row["ms"]) for row in csv_rows(out / "frames.csv")]
    return {
        "mean_ms": statistics.fmean(frame_ms), "median_ms": statistics.median(frame_ms),
        "frames": len(frame_ms), "not_tracking": s["lost_frames"] + s["recovering_frames"],
        "ate": ate(args, sequence, out / "trajectory.txt"), "device": s.get("device", ""),
        "tracking_size": s["settings"].get("tracking_size", ""), "stage_ms": s["stage_ms"],
        "kernels": s["kernel_gpu_ms"], "raycast_steps": s.get("raycast_steps_per_ray"),
        "model_raycasts": s.get("model_raycasts"),
        "reference_frames": s["settings"].get("reference_frames"),
    }


def csv_rows(path):
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    return [dict(zip(header, line.split(","))) for line in lines[1:] if line]


def peer(args, sequence, out):
    shutil.rmtree(out, ignore_errors=True)
    cmd = ["/usr/bin/python3", args.shared / "tools" / "o3d_slam.py", sequence, "--out", out,
           "--voxel", args.voxel, "--raycast-offset-fix", "--max-frames", args.frames,
           "--print-every", "0"]
    run(cmd, str(out) + ".log")
    timing = json.loads((out / "timing.json").read_text())
    # ms_per_frame_*: tracking, integration and raycast, the image reading left out (as ours).
    return {
        "mean_ms": timing["ms_per_frame_mean"], "median_ms": timing["ms_per_frame_median"],
        "frames": timing["frames"], "not_tracking": timing["frames_lost"],
        "ate": ate(args, sequence, out / "trajectory.txt"),
    }


def mm(value):
    return "-" if value is None else "%.1f mm" % (1000 * value)


def report(name, runs):
    print("\n## %s" % name)
    print("| run | frames | mean ms | median ms | fps | ATE | not tracking |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for label, r in runs:
        print("| %s | %d | %.1f | %.1f | %.1f | %s | %d |" % (
            label, r["frames"], r["mean_ms"], r["median_ms"], 1000 / r["mean_ms"], mm(r["ate"]),
            r["not_tracking"]))
    mine = [r for label, r in runs if label.startswith("imufusion")]
    theirs = [r for label, r in runs if label.startswith("Open3D")]
    if mine and theirs:
        ratio = statistics.fmean(r["mean_ms"] for r in theirs) / statistics.fmean(
            r["mean_ms"] for r in mine)
        print("\nOpen3D's mean frame time over ours: %.2f (3 or more: a third of the peer's or less)"
              % ratio)
    last = mine[-1]
    total = last["stage_ms"]["total"]
    print("\nimufusion on %s, tracking at %s, stages (mean ms per frame, share of the frame):"
          % (last["device"], last["tracking_size"]))
    print("  " + ", ".join("%s %.1f (%.0f %%)" % (k, last["stage_ms"][k], 100 * last["stage_ms"][k] / total)
                           for k in STAGES if last["stage_ms"][k] > 0))
    print("  slowest kernels (GPU ms per frame x dispatches per frame): " + ", ".join(
        "%s %.2f x %.1f" % (k["kernel"], k["gpu_ms"], k["dispatches"]) for k in last["kernels"][:6]))
    gpu = sum(k["gpu_ms"] for k in last["kernels"])
    dispatches = sum(k["dispatches"] for k in last["kernels"])
    print("  all kernels %.1f ms of GPU time in %.0f dispatches per frame; the rest of the %.1f ms is"
          " host work and waits" % (gpu, dispatches, total))
    if last["raycast_steps"] is not None:
        print("  the raycast marches %.1f steps per ray (the scan's last model raycast)"
              % last["raycast_steps"])
    if last["model_raycasts"] is not None:
        print("  %d of %d frames raycast the model as ICP's next reference (a reference serves at"
              " most %s frames)" % (last["model_raycasts"], last["frames"], last["reference_frames"]))


def main():
    args = parse_args()
    if not (args.build / "tools" / "imufusion-scan").exists():
        fail("%s/tools/imufusion-scan is missing: build it first" % args.build)
    if (args.render or not args.no_peer) and not (args.shared / "tools").is_dir():
        fail("%s/tools is missing (give --shared, or --no-peer without --render)" % args.shared)
    sequences = [(s.name, s) for s in args.sequence]
    sequences += [("imufusion-synth " + t, generated(args, "synth", t)) for t in args.synth]
    sequences += [("render_sequence.py " + t, generated(args, "render", t)) for t in args.render]
    results = {}
    for name, sequence in sequences:
        if not (sequence / "depth.txt").exists():
            fail("%s is not a sequence (no depth.txt)" % sequence)
        runs = []
        for i in range(args.repeat):
            work = args.work / "runs" / sequence.name
            work.mkdir(parents=True, exist_ok=True)
            t0 = time.monotonic()
            runs.append(("imufusion %d" % (i + 1), ours(args, sequence, work / ("ours%d" % i))))
            print("[%s] imufusion run %d: %.0f s" % (name, i + 1, time.monotonic() - t0),
                  file=sys.stderr, flush=True)
            if not args.no_peer:
                t0 = time.monotonic()
                runs.append(("Open3D %d" % (i + 1), peer(args, sequence, work / ("peer%d" % i))))
                print("[%s] Open3D run %d: %.0f s" % (name, i + 1, time.monotonic() - t0),
                      file=sys.stderr, flush=True)
        report("%s, first %d frames, %.3f m voxels" % (name, args.frames, args.voxel), runs)
        results[name] = runs
    if args.json:
        args.json.write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
