#!/usr/bin/python3
"""Tracking on data the project did not make: ours (imufusion-scan with and without the IMU)
against the Open3D peer, on sequences from the independent renderer (shared/tools) and on the
real TUM fr1_xyz recording, decimated with --frame-step into faster motion.

  /usr/bin/python3 bench/generalization.py                         # room wall fast, seeds 801-810
  /usr/bin/python3 bench/generalization.py --scenes room --seeds 1 --frames 30 --no-tum
  /usr/bin/python3 bench/generalization.py --no-synthetic --tum-max-frames 40 --peer-tum-steps "1 2"

Renders and runs are cached under --work (default /tmp/imufusion-generalization): a run whose
trajectory.txt exists is not run again unless --force; delete a sequence directory to render
it again. The table goes to stdout and, with a JSON of every figure, to WORK/results.{md,json};
progress lines with elapsed seconds go to stderr. Needs ../shared (--shared) and
build/tools/imufusion-scan (--build).

Figures: ATE is eval_traj.py's RMSE after an SE(3) alignment; "max err" is the largest
per-frame position error after the same alignment / without alignment. Initial pose: the peer
runs with --init gt and starts at the ground-truth pose nearest its first frame; imufusion-scan
starts at the identity (its first camera frame is the world). For the unaligned error both
trajectories are anchored the same way, T_gt(first frame) * T_est(first)^-1 * T_est (a no-op
for the peer), so that error is the drift from a start at the true pose (dead reckoning running
away shows there). "lost": frames.csv rows whose status is not tracking (lost or recovering);
for the peer, status.txt "lost" lines; "broken": eval_traj's n_jumps (frame-to-frame error
above 5 cm or 5 deg). "med it": summary.json median_icp_iterations. The ATE, being aligned,
does not depend on the start. Targets (the per-scene lines) are checked on ours with the IMU;
the 0.5 m max error on ours with and without it. The wall scene needs --frames >= 240. The
peer has no frame step: for TUM steps > 1 it runs on a decimated copy of the index files in
WORK/tum (images linked, IMU whole).
"""

import argparse
import concurrent.futures
import json
import math
import os
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

REPO = Path(__file__).resolve().parent.parent
START = time.monotonic()
FPS = 30.0
WALL_MIN_FRAMES = 240  # render_sequence.py needs 8 s of the wall scene
WALL_ONLY_FRACTION = 0.999  # render_sequence.py's wall-only flag (frame_info.txt wall_fraction)
TUM_NAME = "tum_fr1_xyz"

# Targets, in metres where they are lengths.
ROOM_ATE, FAST_ATE, WALL_ATE = 0.010, 0.015, 0.030
TUM_STEP1_ATE, TUM_STEPN_ATE = 0.015, 0.020
MAX_POSITION_ERROR = 0.5
MAX_MEDIAN_ITERATIONS = 2.0

_log_lock = threading.Lock()


def log(message):
    with _log_lock:
        print("[%7.1f s] %s" % (time.monotonic() - START, message), file=sys.stderr, flush=True)


def fail(message):
    sys.exit("generalization.py: error: " + message)


# --------------------------------------------------------------------------- options

def parse_seeds(text):
    """'801-810 3' -> [801, ..., 810, 3]; commas or spaces between items."""
    seeds = []
    for item in text.replace(",", " ").split():
        first, _, last = item.partition("-")
        try:
            lo, hi = int(first), int(last or first)
        except ValueError:
            raise argparse.ArgumentTypeError("not a seed or a range like 801-810: %r" % item)
        if hi < lo:
            raise argparse.ArgumentTypeError("empty seed range %r" % item)
        seeds.extend(range(lo, hi + 1))
    return seeds


def parse_steps(text):
    try:
        steps = [int(s) for s in text.replace(",", " ").split()]
    except ValueError:
        raise argparse.ArgumentTypeError("frame steps are integers >= 1: %r" % text)
    if any(s < 1 for s in steps):
        raise argparse.ArgumentTypeError("frame steps are integers >= 1: %r" % text)
    return steps


def parse_args():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="+", choices=["room", "wall", "fast"], default=["room", "wall", "fast"])
    ap.add_argument("--seeds", nargs="+", default=["801-810"], help="seeds or ranges, e.g. 801-810 3")
    ap.add_argument("--frames", type=int, default=300, help="frames per rendered sequence (default 300)")
    ap.add_argument("--shared", type=Path, default=REPO.parent / "shared", help="default ../shared")
    ap.add_argument("--build", type=Path, default=REPO / "build", help="default build")
    ap.add_argument("--work", type=Path, default=Path("/tmp/imufusion-generalization"))
    ap.add_argument("--force", action="store_true", help="run again the runs that have outputs")
    ap.add_argument("--jobs", type=int, default=1, help="tracker runs at once (default 1)")
    ap.add_argument("--no-peer", action="store_true", help="skip the Open3D peer")
    ap.add_argument("--scan-args", default="",
                    help='extra imufusion-scan options for our runs, e.g. "--tracking-level 0"')
    ap.add_argument("--runs-tag", default="",
                    help="our runs and the peer's go to WORK/runs-TAG (renders are shared)")
    parts = ap.add_mutually_exclusive_group()
    parts.add_argument("--no-imu-run", action="store_true", help="skip ours without the IMU")
    parts.add_argument("--imu-only", action="store_true", help="only ours with the IMU (no peer, no --no-imu)")
    ap.add_argument("--no-synthetic", action="store_true", help="skip the rendered scenes (TUM only)")
    ap.add_argument("--no-tum", action="store_true", help="skip the TUM recording")
    ap.add_argument("--tum-steps", type=parse_steps, default=[1, 2, 3, 4], help='default "1 2 3 4"')
    ap.add_argument("--peer-tum-steps", type=parse_steps, default=[1], help='default "1"')
    ap.add_argument("--tum-max-frames", type=int, default=0,
                    help="scan only the recording's first N frames (before the frame step; 0: all)")
    ap.add_argument("--wall-grace-frames", type=int, default=0,
                    help="frames after the wall stretch allowed to be not tracking (default 0)")
    args = ap.parse_args()
    try:
        args.seeds = parse_seeds(" ".join(args.seeds))
    except argparse.ArgumentTypeError as e:
        ap.error("--seeds: %s" % e)
    if args.imu_only:
        args.no_imu_run = args.no_peer = True
    if args.frames < 3:
        ap.error("--frames must be at least 3")
    if args.no_synthetic:
        args.scenes = []
    if "wall" in args.scenes and args.frames < WALL_MIN_FRAMES:
        ap.error("the wall scene needs --frames >= %d (8 s at 30 fps: render_sequence.py refuses fewer)"
                 % WALL_MIN_FRAMES)
    if args.jobs < 1 or args.tum_max_frames < 0:
        ap.error("--jobs must be >= 1 and --tum-max-frames >= 0")
    return args


def check_prerequisites(args):
    """The shared tools, the dataset and the built scanner: a clear message naming what is missing."""
    args.shared = args.shared.resolve()
    args.tools = args.shared / "tools"
    args.scan = args.build.resolve() / "tools" / "imufusion-scan"
    args.tum = args.shared / "datasets" / TUM_NAME
    if not args.shared.is_dir():
        fail("the shared directory %s is missing (give it with --shared)" % args.shared)
    needed = [args.tools / "render_sequence.py", args.tools / "eval_traj.py"]
    if not args.no_peer:
        needed.append(args.tools / "o3d_slam.py")
    if not args.no_tum:
        needed.append(args.tum / "depth.txt")
    for path in needed:
        if not path.exists():
            fail("%s is missing" % path)
    if not os.access(args.scan, os.X_OK):
        fail("%s is missing: build it (cmake --build %s --target imufusion-scan) or give --build"
             % (args.scan, args.build))


# --------------------------------------------------------------------------- running tools

def run_logged(cmd, log_path):
    """Runs cmd with its output in log_path; True when it exited 0."""
    with open(log_path, "w") as out:
        out.write("$ " + " ".join(str(c) for c in cmd) + "\n")
        out.flush()
        code = subprocess.call([str(c) for c in cmd], stdout=out, stderr=subprocess.STDOUT, cwd=REPO)
    return code == 0


def tail(path, lines=3):
    try:
        return " | ".join(Path(path).read_text().strip().splitlines()[-lines:])
    except OSError:
        return ""


def produce(what, out_dir, cmd, done_file, force=False):
    """Runs cmd into out_dir.tmp and renames it to out_dir when done_file is there (a killed run
    leaves no half output behind). Returns an error message, or None."""
    if (out_dir / done_file).exists() and not force:
        log("%s: cached" % what)
        return None
    tmp = out_dir.with_name(out_dir.name + ".tmp")
    log_file = out_dir.with_name(out_dir.name + ".log")
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    log("%s ..." % what)
    t0 = time.monotonic()
    ok = run_logged([tmp if c == "{out}" else c for c in cmd], log_file)
    if not (tmp / done_file).exists():
        message = "%s failed (log %s): %s" % (what, log_file, tail(log_file))
        log(message)
        return message
    shutil.rmtree(out_dir, ignore_errors=True)
    tmp.rename(out_dir)
    log("%s: %s in %.1f s" % (what, "done" if ok else "done, non-zero exit", time.monotonic() - t0))
    return None if ok else "%s exited non-zero (log %s): %s" % (what, log_file, tail(log_file))


def render(args, scene, seed):
    seq = args.work / "seq" / ("%s_s%d_f%d" % (scene, seed, args.frames))
    workers = max(1, (os.cpu_count() or 1) // args.jobs)
    cmd = ["/usr/bin/python3", args.tools / "render_sequence.py", "--scene", scene, "--seed", seed,
           "--frames", args.frames, "--out", "{out}", "--workers", workers]
    return seq, produce("render %s seed %d (%d frames)" % (scene, seed, args.frames), seq, cmd, "frame_info.txt")


def data_lines(path):
    """The lines of a text file that are neither empty nor # comments."""
    return [l for l in Path(path).read_text().splitlines() if l.strip() and not l.startswith("#")]


def decimated_copy(src, dst, step, max_frames):
    """The first max_frames (0: all) depth frames of src, every step-th, for the peer: depth.txt
    decimated, rgb.txt the colour frame nearest each kept depth frame, every other file and the
    image directories linked (the IMU stream stays whole)."""
    if (dst / "depth.txt").exists():
        return dst
    shutil.rmtree(dst, ignore_errors=True)
    dst.mkdir(parents=True)
    depth = data_lines(src / "depth.txt")
    kept = depth[:max_frames or len(depth)][::step]
    for entry in src.iterdir():
        if entry.name not in ("depth.txt", "rgb.txt"):
            (dst / entry.name).symlink_to(entry.resolve())
    if (src / "rgb.txt").exists():
        rgb = data_lines(src / "rgb.txt")
        stamps = np.array([float(l.split()[0]) for l in rgb])
        nearest = [rgb[int(np.argmin(np.abs(stamps - float(l.split()[0]))))] for l in kept]
        (dst / "rgb.txt").write_text("# every %d-th colour frame\n%s\n" % (step, "\n".join(nearest)))
    (dst / "depth.txt").write_text("# every %d-th depth frame of %s\n%s\n" % (step, src, "\n".join(kept)))
    return dst


# --------------------------------------------------------------------------- the runs

class Run:
    """One tracker on one sequence: kind is imu, noimu or o3d."""

    def __init__(self, kind, seq, out, extra=()):
        self.kind, self.seq, self.out, self.extra = kind, seq, out, list(extra)
        self.error = None

    def command(self, args):
        if self.kind == "o3d":
            return ["/usr/bin/python3", args.tools / "o3d_slam.py", self.seq, "--out", "{out}",
                    "--raycast-offset-fix", "--init", "gt", "--print-every", "0"] + self.extra
        flags = ["--no-imu"] if self.kind == "noimu" else []
        return ([args.scan, self.seq, "--out", "{out}", "--quiet"] + flags + self.extra +
                args.scan_args.split())

    def execute(self, args):
        what = "%s on %s" % ({"imu": "ours+IMU", "noimu": "ours no IMU", "o3d": "Open3D"}[self.kind],
                             self.out.parent.name)
        self.error = produce(what, self.out, self.command(args), "trajectory.txt", args.force)


def runs_root(args):
    return args.work / ("runs-" + args.runs_tag if args.runs_tag else "runs")


def scene_runs(args, seq, name):
    root = runs_root(args) / name
    kinds = ["imu"] + ([] if args.no_imu_run else ["noimu"]) + ([] if args.no_peer else ["o3d"])
    return {k: Run(k, seq, root / k) for k in kinds}


def tum_runs(args, step):
    first = "_first%d" % args.tum_max_frames if args.tum_max_frames else ""
    root = runs_root(args) / ("%s%s_step%d" % (TUM_NAME, first, step))
    ours = ["--frame-step", step]
    if args.tum_max_frames:
        ours += ["--frames", math.ceil(args.tum_max_frames / step)]
    runs = {"imu": Run("imu", args.tum, root / "imu", ours)}
    if not args.no_imu_run:
        runs["noimu"] = Run("noimu", args.tum, root / "noimu", ours)
    if not args.no_peer and step in args.peer_tum_steps:
        if step == 1:
            peer = ["--max-frames", args.tum_max_frames] if args.tum_max_frames else []
            runs["o3d"] = Run("o3d", args.tum, root / "o3d", peer)
        else:
            copy = decimated_copy(args.tum, args.work / "tum" / ("step%d%s" % (step, first)), step,
                                  args.tum_max_frames)
            runs["o3d"] = Run("o3d", copy, root / "o3d")
    return runs


def execute_all(args, runs):
    with concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as pool:
        for future in [pool.submit(r.execute, args) for r in runs]:
            future.result()


# --------------------------------------------------------------------------- evaluation

def read_tum(path):
    rows = np.array([[float(x) for x in l.split()[:8]] for l in data_lines(path)]).reshape(-1, 8)
    poses = np.tile(np.eye(4), (len(rows), 1, 1))
    poses[:, :3, :3] = Rotation.from_quat(rows[:, 4:8]).as_matrix()
    poses[:, :3, 3] = rows[:, 1:4]
    return rows[:, 0], poses


def write_anchored(gt_path, est_path, out_path, max_diff=0.02):
    """est moved so that its first pose is the ground-truth pose nearest it; False if none is."""
    t_gt, T_gt = read_tum(gt_path)
    t_est, T_est = read_tum(est_path)
    k = int(np.argmin(np.abs(t_gt - t_est[0])))
    if abs(t_gt[k] - t_est[0]) > max_diff:
        return False
    T = T_gt[k] @ np.linalg.inv(T_est[0]) @ T_est
    q = Rotation.from_matrix(T[:, :3, :3]).as_quat()
    lines = ["%.6f %.6f %.6f %.6f %.9f %.9f %.9f %.9f" % (t, *T[i, :3, 3], *q[i]) for i, t in enumerate(t_est)]
    Path(out_path).write_text("# anchored at the first ground-truth pose\n" + "\n".join(lines) + "\n")
    return True


def eval_traj(args, gt, est, *flags):
    out = subprocess.run(["/usr/bin/python3", str(args.tools / "eval_traj.py"), str(gt), str(est), *flags],
                         capture_output=True, text=True)
    if out.returncode != 0:
        raise RuntimeError("eval_traj.py %s %s: %s" % (gt, est, (out.stderr or out.stdout).strip()[-200:]))
    return json.loads(out.stdout)


def tracking_counts(run):
    """(frames, lost, per-frame (timestamp, tracking?)) from frames.csv or the peer's status.txt."""
    if run.kind == "o3d":
        rows = [l.split() for l in data_lines(run.out / "status.txt")]
        frames = [(float(r[0]), r[1] != "lost") for r in rows]
    else:
        lines = (run.out / "frames.csv").read_text().splitlines()
        header = lines[0].split(",")
        t, status = header.index("timestamp"), header.index("status")
        frames = [(float(f[t]), f[status] == "tracking") for f in (l.split(",") for l in lines[1:] if l)]
    return len(frames), sum(not ok for _, ok in frames), frames


def evaluate(args, run, gt):
    """The figures of one run, or {'error': ...}."""
    if run.error and not (run.out / "trajectory.txt").exists():
        return {"error": run.error}
    est = run.out / "trajectory.txt"
    aligned = eval_traj(args, gt, est, "--errors-out", run.out / "errors.txt")
    errors = np.loadtxt(run.out / "errors.txt", ndmin=2)
    frames, lost, per_frame = tracking_counts(run)
    figures = {"frames": frames, "lost": lost, "ate": aligned["ate_rmse"], "broken": aligned["n_jumps"],
               "max_err": float(errors[:, 1].max()), "max_err_time": float(errors[errors[:, 1].argmax(), 0]),
               "matched": aligned["n_associated"], "max_err_raw": None, "per_frame": per_frame}
    if write_anchored(gt, est, run.out / "trajectory_anchored.txt"):
        figures["max_err_raw"] = eval_traj(args, gt, run.out / "trajectory_anchored.txt", "--no-align")["ate_max"]
    if run.kind != "o3d":
        figures["median_it"] = json.loads((run.out / "summary.json").read_text()).get("median_icp_iterations")
    if run.error:
        figures["warning"] = run.error
    return figures


def wall_stretch_end(seq):
    """Timestamp of the last wall-only frame (frame_info.txt wall_fraction), None if none."""
    rows = np.loadtxt(seq / "frame_info.txt", ndmin=2)
    wall = rows[rows[:, 2] > WALL_ONLY_FRACTION]
    return float(wall[:, 0].max()) if len(wall) else None


def untracked_after(figures, t_end, grace):
    after = [ok for t, ok in figures["per_frame"] if t > t_end + 1e-6]
    return sum(not ok for ok in after[grace:]), len(after)


# --------------------------------------------------------------------------- targets

def ok(figures):
    return bool(figures) and "error" not in figures


def check(checks, name, value):
    checks[name] = None if value is None else bool(value)


def leq(a, b):
    return None if a is None or b is None else a <= b


def scan_checks(args, row):
    """Target name -> True / False / None (not measured) for one scan row."""
    imu, noimu, o3d = (row["runs"].get(k, {}) for k in ("imu", "noimu", "o3d"))
    c = {}
    if not ok(imu):
        return {"ours with IMU ran": False}
    kind = row["scene"]
    if kind == "room":
        check(c, "room: every frame tracks", imu["lost"] == 0)
        check(c, "room: ATE <= 10 mm", imu["ate"] <= ROOM_ATE)
    elif kind == "fast":
        check(c, "fast: ATE <= 15 mm", imu["ate"] <= FAST_ATE)
    elif kind == "wall":
        check(c, "wall: ATE <= 30 mm", imu["ate"] <= WALL_ATE)
        check(c, "wall: every frame after the wall stretch tracks",
              None if row.get("untracked_after_wall") is None else row["untracked_after_wall"] == 0)
    elif kind == "tum":
        if row["step"] == 1:
            check(c, "tum step 1: ATE <= 15 mm", imu["ate"] <= TUM_STEP1_ATE)
        else:
            check(c, "tum steps 2+: no frame lost", imu["lost"] == 0)
            check(c, "tum steps 2+: ATE <= 20 mm", imu["ate"] <= TUM_STEPN_ATE)
    if kind in ("room", "fast"):
        check(c, "IMU ATE <= Open3D ATE", leq(imu["ate"], o3d.get("ate")) if ok(o3d) else None)
    for name, f in (("IMU", imu), ("no IMU", noimu)):
        if ok(f):
            worst = max(f["max_err"], f["max_err_raw"] if f["max_err_raw"] is not None else 0.0)
            check(c, "max position error <= 0.5 m (%s)" % name, worst <= MAX_POSITION_ERROR)
    check(c, "IMU median iterations <= 2", leq(imu.get("median_it"), MAX_MEDIAN_ITERATIONS))
    check(c, "IMU ATE <= no-IMU ATE", leq(imu["ate"], noimu.get("ate")) if ok(noimu) else None)
    return c


# --------------------------------------------------------------------------- report

def mm(v):
    return "-" if v is None else "%.1f" % (1000 * v)


def cells(f, peer=False):
    if not f:
        return ["-"] * (3 if peer else 4)
    if "error" in f:
        return ["failed"] + ["-"] * (2 if peer else 3)
    lost = "%d/%d" % (f["lost"], f["broken"]) if peer else "%d" % f["lost"]
    row = [mm(f["ate"]), lost, "%s / %s" % (mm(f["max_err"]), mm(f["max_err_raw"]))]
    return row if peer else row + ["-" if f.get("median_it") is None else "%g" % f["median_it"]]


def table(rows):
    head = ["scan", "IMU ATE mm", "IMU lost", "IMU max err mm (al/raw)", "IMU med it",
            "no-IMU ATE mm", "no-IMU lost", "no-IMU max err mm (al/raw)", "no-IMU med it",
            "Open3D ATE mm", "Open3D lost/broken", "Open3D max err mm (al/raw)"]
    lines = ["| " + " | ".join(head) + " |", "|" + " --- |" * len(head)]
    for r in rows:
        runs = r["runs"]
        line = [r["label"]] + cells(runs.get("imu")) + cells(runs.get("noimu")) + cells(runs.get("o3d"), peer=True)
        lines.append("| " + " | ".join(line) + " |")
    return "\n".join(lines)


def summary(rows):
    lines = []
    for scene in dict.fromkeys(r["scene"] for r in rows):
        group = [r for r in rows if r["scene"] == scene]
        met = sum(all(v is not False for v in r["checks"].values()) for r in group)
        unit = "steps" if scene == "tum" else "seeds"
        lines.append("%s: %d %s run, %d meet every target measured" % (scene, len(group), unit, met))
        names = dict.fromkeys(n for r in group for n in r["checks"])
        for name in names:
            values = [r["checks"].get(name) for r in group]
            failed = [r["label"] for r, v in zip(group, values) if v is False]
            measured = sum(v is not None for v in values)
            lines.append("  - %s: %d/%d%s" % (name, measured - len(failed), measured,
                                              " (fails: %s)" % ", ".join(failed) if failed else ""))
        if scene == "wall":
            for r in group:
                if r.get("untracked_after_wall"):
                    lines.append("  - %s: %d of %d frames after the wall stretch not tracking"
                                 % (r["label"], r["untracked_after_wall"], r["frames_after_wall"]))
    return "\n".join(lines)


def write_results(args, rows, text):
    for r in rows:
        for f in r["runs"].values():
            f.pop("per_frame", None)
    (args.work / "results.md").write_text(text + "\n")
    settings = {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(args).items()}
    (args.work / "results.json").write_text(json.dumps({"settings": settings, "scans": rows}, indent=1) + "\n")


# --------------------------------------------------------------------------- main

def plan(args):
    """Renders the synthetic sequences; returns (row stubs, runs) for every scan."""
    scans = []
    for scene in args.scenes:
        for seed in args.seeds:
            seq, error = render(args, scene, seed)
            row = {"scene": scene, "seed": seed, "label": "%s s%d" % (scene, seed), "seq": str(seq)}
            if error:
                row["error"] = error
                scans.append((row, {}))
            else:
                scans.append((row, scene_runs(args, seq, seq.name)))
    if not args.no_tum:
        for step in args.tum_steps:
            row = {"scene": "tum", "step": step, "label": "tum step %d" % step, "seq": str(args.tum)}
            scans.append((row, tum_runs(args, step)))
    return scans


def evaluate_scan(args, row, runs):
    gt = Path(row["seq"]) / "groundtruth.txt"
    row["runs"] = {}
    for kind, run in runs.items():
        try:
            row["runs"][kind] = evaluate(args, run, gt)
        except (RuntimeError, OSError, ValueError) as e:
            row["runs"][kind] = {"error": str(e)}
    imu = row["runs"].get("imu", {})
    if row["scene"] == "wall" and ok(imu):
        t_end = wall_stretch_end(Path(row["seq"]))
        if t_end is not None:
            row["untracked_after_wall"], row["frames_after_wall"] = untracked_after(imu, t_end, args.wall_grace_frames)
    row["checks"] = scan_checks(args, row) if "error" not in row else {"rendered": False}
    return row


def main():
    args = parse_args()
    check_prerequisites(args)
    args.work.mkdir(parents=True, exist_ok=True)
    scans = plan(args)
    execute_all(args, [run for _, runs in scans for run in runs.values()])
    rows = [evaluate_scan(args, row, runs) for row, runs in scans]
    text = table(rows) + "\n\n" + summary(rows)
    print(text)
    write_results(args, rows, text)
    log("results in %s/results.{md,json}" % args.work)


if __name__ == "__main__":
    main()
