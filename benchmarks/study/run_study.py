#!/usr/bin/python3
"""Runs `rodmesh optimize` with every method on every design-study scene, one
run after another, each with one thread and a wall-clock limit.

    /usr/bin/python3 benchmarks/study/run_study.py --rodmesh build/apps/rodmesh \
        --scenes SCENEDIR --out RUNDIR [--experiments sheet,hat,dino,smiley] \
        [--methods sand,reduced,newton] [--schedule S] [--time-limit 600] \
        [--max-iter 100000] [--reuse]

Each method runs with its default schedule (SAND levels, reduced paper,
newton joint: what a user gets) unless --schedule names one for all.

For each experiment E and method M: RUNDIR/E_M.h5 (the archive), RUNDIR/E_M.log
(the progress lines) and an entry in RUNDIR/runs.json: the command, exit
status, wall time of the whole process (start-up, optimization, re-solves from
rest and archive included), its peak resident memory, the limits and the load
average before and after. `--reuse` keeps an archive made with the same
binary, scene and limits and only rereads it.
"""
import argparse
import hashlib
import json
import os
import subprocess
import sys
import time


def digest(path):
    h = hashlib.sha1()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()[:16]


def run_one(cmd, log):
    """Runs cmd with stderr/stdout into log; returns (exit status, wall s, peak RSS bytes)."""
    t0 = time.time()
    with open(log, "w") as lf:
        p = subprocess.Popen(cmd, stdout=lf, stderr=subprocess.STDOUT)
        _, status, usage = os.wait4(p.pid, 0)
    wall = time.time() - t0
    code = os.waitstatus_to_exitcode(status)
    p.returncode = code
    return code, wall, usage.ru_maxrss * 1024


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rodmesh", required=True)
    ap.add_argument("--scenes", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--experiments", default="sheet,hat,dino,smiley")
    ap.add_argument("--methods", default="sand,reduced,newton")
    ap.add_argument("--schedule", default="", help="one schedule for every method (default: each method's own)")
    ap.add_argument("--time-limit", type=float, default=600.0)
    ap.add_argument("--max-iter", type=int, default=100000)
    ap.add_argument("--reuse", action="store_true")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    runs_path = os.path.join(a.out, "runs.json")
    runs = json.load(open(runs_path)) if os.path.exists(runs_path) else {}
    binary = digest(a.rodmesh)
    root = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
    git = lambda *args: subprocess.run(["git"] + list(args), cwd=root, stdout=subprocess.PIPE,
                                       stderr=subprocess.DEVNULL, text=True).stdout.strip()
    commit = git("rev-parse", "--short", "HEAD") + (" (with uncommitted changes)" if git(
        "status", "--porcelain", "--untracked-files=no") else "")
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    failed = False
    for e in a.experiments.split(","):
        scene = os.path.join(a.scenes, e + ".json")
        if not os.path.exists(scene):
            print("run_study.py: no scene %s (run make_scenes.py first)" % scene, file=sys.stderr)
            return 2
        for m in a.methods.split(","):
            key = "%s_%s" % (e, m)
            out = os.path.join(a.out, key + ".h5")
            log = os.path.join(a.out, key + ".log")
            cmd = [a.rodmesh, "optimize", scene, "-o", out, "--method", m] + (
                ["--schedule", a.schedule] if a.schedule else []) + [
                "--threads", "1", "--time-limit", "%g" % a.time_limit, "--max-iter", str(a.max_iter)]
            spec = dict(binary=binary, scene=digest(scene), time_limit=a.time_limit, max_iter=a.max_iter,
                        schedule=a.schedule or "default")
            old = runs.get(key)
            if a.reuse and old and os.path.exists(out) and all(old.get(k) == v for k, v in spec.items()):
                print("%s: reusing %s" % (key, out))
                continue
            load0 = os.getloadavg()
            started = time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime())
            print("%s: %s" % (key, " ".join(cmd)), flush=True)
            old_env = os.environ.copy()
            os.environ.update(env)
            try:
                code, wall, rss = run_one(cmd, log)
            finally:
                os.environ.clear()
                os.environ.update(old_env)
            load1 = os.getloadavg()
            runs[key] = dict(spec, experiment=e, method=m, command=" ".join(cmd), exit=code, wall_s=wall,
                             peak_rss_bytes=rss, started=started, commit=commit, load_before=load0[0], load_after=load1[0])
            print("%s: exit %d, %.1f s wall, peak RSS %.0f MiB, load %.1f -> %.1f" % (
                key, code, wall, rss / 2**20, load0[0], load1[0]), flush=True)
            if code not in (0, 1) or not os.path.exists(out):
                print("%s: no archive (exit %d), see %s" % (key, code, log), file=sys.stderr)
                failed = True
            with open(runs_path + ".tmp", "w") as f:
                json.dump(runs, f, indent=1)
            os.replace(runs_path + ".tmp", runs_path)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
