#!/usr/bin/python3
"""Runs `rodmesh optimize` with DEFAULT flags on the cases of make_cases.py and
judges each run the way acceptance does: exit status, the RMS of the archived
design re-simulated from scratch by `rodmesh simulate`, and time.

    /usr/bin/python3 benchmarks/defaults/run_defaults.py --rodmesh BIN --cases DIR \
        --out results.csv [--methods sand,reduced] [--only a,b] [--extra "flags..."] \
        [--limit-runs] [--work DIR] [--timeout 600]

Per case and method: `BIN optimize CASE.json -o OUT.h5 --method M` (plus
--extra), nothing else; wall time, user+sys CPU of the process
(getrusage(RUSAGE_CHILDREN) deltas), exit status and the last progress lines.
The archive is read with h5py; then its design is re-simulated from scratch:
a scene with vertices = /rest/positions, radii = /design/radii and the same
poses (no design block), run by `BIN simulate`, and the RMS of the
re-simulated positions against the targets,
sqrt(sum |q - target|^2 / (poses * vertices)), is compared with the archived
one. A run longer than --timeout (600 s) is sent SIGINT (it archives its best
design), then SIGKILL 60 s later, and recorded with exit "timeout".

`--limit-runs` adds, when those cases are selected: on sheet_unreachable SAND
with `--time-limit 4`, and SAND sent SIGINT 4 s after start (answered_in_s:
seconds from SIGINT to the process's exit); on hat_both SAND with
`--time-limit 30` (over_limit_s: wall time beyond the limit).

Writes the CSV, a Markdown table next to it (same name, .md) with the machine
(nproc, load average from `uptime` at start and end), and the archives and
logs into --work (default: DIR/runs). One rodmesh process at a time.
"""
import argparse
import csv
import hashlib
import json
import math
import os
import resource
import shlex
import signal
import subprocess
import sys
import time

import h5py
import numpy as np

CASE_ORDER = ["small_radii", "small_rest", "small_both", "sheet_unreachable", "hat_radii", "hat_both"]

COLUMNS = ["case", "variant", "method", "exit", "status", "wall_s", "cpu_s", "iterations", "initial_rms_mm",
           "archived_rms_mm", "resim_rms_mm", "ratio", "resim_matches", "resim_max_diff_mm", "resim_status",
           "answered_in_s", "over_limit_s", "archived_design", "optimizer_time_s", "peak_mib", "vertices", "poses",
           "flags", "message", "last_lines"]


def sh(cmd):
    return subprocess.run(cmd, shell=True, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True).stdout.strip()


def digest(path):
    h = hashlib.sha1()
    with open(path, "rb") as f:
        for b in iter(lambda: f.read(1 << 20), b""):
            h.update(b)
    return h.hexdigest()[:12]


def cpu_children():
    u = resource.getrusage(resource.RUSAGE_CHILDREN)
    return u.ru_utime + u.ru_stime


def run_process(cmd, log, timeout, sigint_after=None):
    """Runs cmd (stdout+stderr to log). Returns dict(exit, wall_s, cpu_s, answered_in_s, timed_out)."""
    c0 = cpu_children()
    t0 = time.perf_counter()
    res = dict(answered_in_s=None, timed_out=False)
    with open(log, "w") as lf:
        # SIGINT at its default disposition in the child: a runner started in
        # the background of a non-interactive shell (or under nohup) has it
        # ignored, and rodmesh keeps ignored signals ignored.
        p = subprocess.Popen(cmd, stdout=lf, stderr=subprocess.STDOUT,
                             preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
        t_int = None
        if sigint_after is not None:
            try:
                p.wait(timeout=sigint_after)
            except subprocess.TimeoutExpired:
                p.send_signal(signal.SIGINT)
                t_int = time.perf_counter()
        try:
            p.wait(timeout=max(1.0, timeout - (time.perf_counter() - t0)))
        except subprocess.TimeoutExpired:
            res["timed_out"] = True
            p.send_signal(signal.SIGINT)
            try:
                p.wait(timeout=60)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        t1 = time.perf_counter()
        if t_int is not None:
            res["answered_in_s"] = t1 - t_int
    res["exit"] = p.returncode
    res["wall_s"] = t1 - t0
    res["cpu_s"] = cpu_children() - c0
    return res


def last_lines(log, n=2):
    """The last progress line, the optimizer's summary line and the last n lines of the log."""
    try:
        lines = [l.rstrip() for l in open(log, errors="replace") if l.strip()]
    except OSError:
        return ""
    it = [l for l in lines if l.startswith("iter ")][-1:]
    summary = [l for l in lines if l.startswith("optimizer:")][-1:]
    tail = [l for l in lines[-n:] if l not in it + summary]
    return " | ".join(it + summary + tail)


def astr(v):
    return v.decode() if isinstance(v, bytes) else str(v)


def rms(positions, targets):
    s, n = 0.0, 0
    for name, t in targets.items():
        q = positions[name]
        s += float(((q - t) ** 2).sum())
        n += len(q)
    return math.sqrt(s / n)


def read_archive(path):
    with h5py.File(path, "r") as f:
        a = dict(f.attrs)
        scene = json.loads(f["scene"].asstr()[()] if f["scene"].shape == () else astr(f["scene"][0]))
        names = [p["name"] for p in scene["poses"]]
        pos = {n: f["poses"][n]["positions"][()] for n in names}
        tgt = {n: np.asarray(p["target"], float) for n, p in zip(names, (p for p in scene["poses"]))}
        init = {n: f["poses"][n]["initial_positions"][()] for n in names if "initial_positions" in f["poses"][n]}
        pose_rms = {n: float(f["poses"][n].attrs.get("rms_error", float("nan"))) for n in names}
        h = f["history"] if "history" in f else None
        hist = dict(rms=h["rms_error"][()], t=h["time_s"][()]) if h is not None else None
        return dict(
            status=astr(a.get("status", "")), message=astr(a.get("message", "")),
            iterations=int(a.get("iterations", -1)), time_s=float(a.get("time_s", float("nan"))),
            archived_design=astr(a.get("archived_design", "")),
            peak_mib=float(a.get("peak_memory_bytes", 0)) / 2**20,
            scene=scene, rest=f["rest/positions"][()], radii=f["design/radii"][()], positions=pos, targets=tgt,
            initial=init, pose_rms=pose_rms, history=hist)


def resimulate(rodmesh, arch, work, tag, timeout):
    """Simulates the archived design from scratch; returns (positions, status, exit)."""
    s = dict(arch["scene"])
    s.pop("design", None)
    s.pop("radius", None)
    s["vertices"] = arch["rest"].tolist()
    s["radii"] = arch["radii"].tolist()
    path = os.path.join(work, tag + ".resim.json")
    with open(path, "w") as f:
        json.dump(s, f)
    out = path[:-5] + ".h5"
    if os.path.exists(out):
        os.remove(out)
    r = subprocess.run([rodmesh, "simulate", path, "-o", out, "-q"], stdout=subprocess.PIPE,
                       stderr=subprocess.PIPE, text=True, timeout=timeout)
    if not os.path.exists(out):
        return None, "no archive (exit %d): %s" % (r.returncode, r.stderr.strip()[-300:]), r.returncode
    with h5py.File(out, "r") as f:
        pos = {p["name"]: f["poses"][p["name"]]["positions"][()] for p in s["poses"]}
        st = [astr(f["poses"][p["name"]].attrs.get("status", "")) for p in s["poses"]]
    status = "converged" if all(x == "converged" for x in st) else ",".join(st)
    return pos, status, r.returncode


def fmt(x, d=4, g=False):
    """x with d decimals (g: d significant digits); "" for None or nan."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return ""
    if not isinstance(x, float):
        return str(x)
    return ("%%.%dg" % d) % x if g else ("%%.%df" % d) % x


def one_run(a, case, method, variant, flags, work, sigint_after=None, time_limit=None):
    scene_path = os.path.join(a.cases, case + ".json")
    tag = "%s_%s_%s" % (case, method, variant)
    out = os.path.join(work, tag + ".h5")
    log = os.path.join(work, tag + ".log")
    if os.path.exists(out):
        os.remove(out)
    cmd = [a.rodmesh, "optimize", scene_path, "-o", out, "--method", method] + flags + shlex.split(a.extra)
    print("[%s] %s" % (time.strftime("%H:%M:%S"), " ".join(cmd)), flush=True)
    r = run_process(cmd, log, a.timeout, sigint_after=sigint_after)
    row = dict(case=case, variant=variant, method=method, flags=" ".join(flags + shlex.split(a.extra)),
               exit="timeout" if r["timed_out"] else r["exit"], wall_s=fmt(r["wall_s"], 2), cpu_s=fmt(r["cpu_s"], 2),
               answered_in_s=fmt(r["answered_in_s"], 2),
               over_limit_s=fmt(r["wall_s"] - time_limit, 2) if time_limit else "",
               last_lines=last_lines(log))
    if not os.path.exists(out):
        row["status"] = "no archive"
        return row
    arch = read_archive(out)
    tg = arch["targets"]
    row.update(status=arch["status"], iterations=arch["iterations"], message=arch["message"],
               archived_design=arch["archived_design"], optimizer_time_s=fmt(arch["time_s"], 2),
               peak_mib=fmt(arch["peak_mib"], 0), vertices=len(arch["rest"]), poses=len(tg))
    r0 = rms(arch["initial"], tg) if len(arch["initial"]) == len(tg) else float("nan")
    # archived RMS: from the per-pose rms_error attributes (every pose has V vertices)
    r_arch = math.sqrt(sum(v * v for v in arch["pose_rms"].values()) / len(arch["pose_rms"]))
    r_pos = rms(arch["positions"], tg)
    pos, st, _ = resimulate(a.rodmesh, arch, work, tag, a.timeout)
    row.update(initial_rms_mm=fmt(1e3 * r0, 4, True), archived_rms_mm=fmt(1e3 * r_arch, 4, True), resim_status=st)
    if pos is not None:
        r_sim = rms(pos, tg)
        diff = max(float(np.linalg.norm(pos[n] - arch["positions"][n], axis=1).max()) for n in pos)
        match = abs(r_sim - r_arch) <= 1e-3 * max(r_arch, 1e-6) + 1e-9 and abs(r_pos - r_arch) <= 1e-6 * max(r_arch, 1e-6) + 1e-12
        row.update(resim_rms_mm=fmt(1e3 * r_sim, 4, True), ratio=fmt(r_sim / r0 if r0 > 0 else float("nan"), 3, True),
                   resim_matches="yes" if match else "NO", resim_max_diff_mm=fmt(1e3 * diff, 3, True))
    else:
        row.update(resim_matches="NO")
    print("    exit %s, %s, %s s wall, %s s cpu, %s it, RMS %s -> archived %s, re-simulated %s mm (ratio %s)%s" % (
        row["exit"], row["status"], row["wall_s"], row["cpu_s"], row.get("iterations", ""), row["initial_rms_mm"],
        row["archived_rms_mm"], row.get("resim_rms_mm", ""), row.get("ratio", ""),
        (", answered SIGINT in %s s" % row["answered_in_s"]) if row["answered_in_s"] else ""), flush=True)
    return row


MD_COLUMNS = [("case", "case"), ("variant", "variant"), ("method", "method"), ("exit", "exit"), ("status", "status"),
              ("wall_s", "wall s"), ("cpu_s", "cpu s"), ("iterations", "iter"), ("initial_rms_mm", "initial RMS mm"),
              ("archived_rms_mm", "archived RMS mm"), ("resim_rms_mm", "re-sim RMS mm"), ("ratio", "re-sim/initial"),
              ("resim_matches", "re-sim = archived"), ("resim_max_diff_mm", "re-sim vs archived max mm"),
              ("answered_in_s", "SIGINT answered in s"), ("over_limit_s", "over limit s")]


def write_outputs(a, rows, machine):
    with open(a.out + ".tmp", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: r.get(k, "") for k in COLUMNS})
    os.replace(a.out + ".tmp", a.out)
    md = os.path.splitext(a.out)[0] + ".md"
    L = ["# rodmesh optimize with default flags", "",
         "Generated by `benchmarks/defaults/run_defaults.py` (cases: `benchmarks/defaults/make_cases.py`).", ""]
    for k, v in machine.items():
        L.append("- %s: %s" % (k, v))
    L += ["", "RMS in mm against the targets; *re-sim* is the archived design (rest positions, radii) simulated "
          "from scratch by `rodmesh simulate`; *re-sim = archived* checks it against the archive's RMS "
          "(relative 1e-3). cpu s is user+sys of the optimize process.", "",
          "| " + " | ".join(h for _, h in MD_COLUMNS) + " |", "|" + "---|" * len(MD_COLUMNS)]
    for r in rows:
        L.append("| " + " | ".join(str(r.get(k, "")) for k, _ in MD_COLUMNS) + " |")
    L += ["", "Messages (archive root attribute `message`):", ""]
    for r in rows:
        L.append("- %s %s %s: %s" % (r["case"], r["method"], r["variant"], r.get("message", "") or r.get("status", "")))
    with open(md + ".tmp", "w") as f:
        f.write("\n".join(L) + "\n")
    os.replace(md + ".tmp", md)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rodmesh", required=True)
    ap.add_argument("--cases", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--methods", default="sand,reduced")
    ap.add_argument("--only", default="")
    ap.add_argument("--extra", default="")
    ap.add_argument("--limit-runs", action="store_true")
    ap.add_argument("--work", default="")
    ap.add_argument("--timeout", type=float, default=600.0)
    a = ap.parse_args()
    a.rodmesh = os.path.abspath(a.rodmesh)
    if a.only:
        cases = a.only.split(",")
    else:
        present = [n[:-5] for n in os.listdir(a.cases) if n.endswith(".json") and not n.endswith(".hidden.json")
                   and n != "cases.json"]
        cases = [c for c in CASE_ORDER if c in present] + sorted(c for c in present if c not in CASE_ORDER)
    for c in cases:
        if not os.path.exists(os.path.join(a.cases, c + ".json")):
            print("run_defaults.py: no scene %s/%s.json (run make_cases.py)" % (a.cases, c), file=sys.stderr)
            return 2
    work = a.work or os.path.join(a.cases, "runs")
    os.makedirs(work, exist_ok=True)
    machine = {"binary": "%s (sha1 %s)" % (a.rodmesh, digest(a.rodmesh)), "nproc": sh("nproc"),
               "uptime at start": sh("uptime"), "started": time.strftime("%Y-%m-%d %H:%M:%S %Z"),
               "methods": a.methods, "extra flags": a.extra or "(none)", "per-run timeout": "%g s" % a.timeout}
    rows = []
    for c in cases:
        for m in [m for m in a.methods.split(",") if m]:  # --methods "": only the limit runs
            rows.append(one_run(a, c, m, "default", [], work))
            write_outputs(a, rows, dict(machine, **{"uptime at end": "(running)"}))
    if a.limit_runs:
        if "sheet_unreachable" in cases:
            rows.append(one_run(a, "sheet_unreachable", "sand", "time_limit_4", ["--time-limit", "4"], work,
                                time_limit=4.0))
            write_outputs(a, rows, dict(machine, **{"uptime at end": "(running)"}))
            rows.append(one_run(a, "sheet_unreachable", "sand", "sigint_4", [], work, sigint_after=4.0))
            write_outputs(a, rows, dict(machine, **{"uptime at end": "(running)"}))
        if "hat_both" in cases:
            rows.append(one_run(a, "hat_both", "sand", "time_limit_30", ["--time-limit", "30"], work,
                                time_limit=30.0))
    machine["uptime at end"] = sh("uptime")
    machine["finished"] = time.strftime("%Y-%m-%d %H:%M:%S %Z")
    write_outputs(a, rows, machine)
    return 0


if __name__ == "__main__":
    sys.exit(main())
