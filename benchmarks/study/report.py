#!/usr/bin/python3
"""The design study's results from its archives: the Table 1 analogue (with the
paper's numbers alongside), RMS against wall time (CSV + PNG per experiment),
the time each halving of the RMS costs, pictures of every pose
(scripts/render.py), as one Markdown file naming the machine and the commit.

    /usr/bin/python3 benchmarks/study/report.py --scenes SCENEDIR --runs RUNDIR \
        --assets ASSETDIR --md OUT.md [--title TEXT] [--notes NOTES.md] [--no-render]

ASSETDIR receives rms_time_E.csv, rms_time_E.png, render_E_M.png; OUT.md links
them relatively. If ASSETDIR/sweeps.md exists (benchmarks/study/sweeps.py),
it is included. NOTES.md (hand-written discussion) is included verbatim.

    /usr/bin/python3 benchmarks/study/report.py --update-sweeps --assets ASSETDIR --md OUT.md

rewrites only the sweeps section at the end of an existing OUT.md from
ASSETDIR/sweeps.md (after sweeps parts were re-run and merged with
merge_sweeps.py), without the optimizer runs' archives.
"""
import argparse
import json
import os
import platform
import re
import subprocess
import sys
import time

os.environ.setdefault("MPLBACKEND", "Agg")

import h5py  # noqa: E402
import numpy as np  # noqa: E402
import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))
EXPERIMENTS = ["sheet", "hat", "dino", "smiley"]
METHODS = ["sand", "reduced", "newton"]
METHOD_NAME = {"sand": "SAND", "reduced": "reduced BFGS", "newton": "reduced Newton-CG"}
COLOUR = {"sand": "#1f77b4", "reduced": "#ff7f0e", "newton": "#2ca02c"}
# An iterate whose largest equilibrium residual is at most this is counted as
# a design with known RMS (the reduced method's iterates are equilibria; SAND's
# are not until its constraints are met).
EQUILIBRIUM_N = 1e-6

# Pérez et al. 2015, Table 1 and §5 (RMS after radii only from the text).
PAPER = {
    "sheet": dict(nodes=693, edges=710, rods=71, connections=54, material=392, rest=588, E=32, nu=0.48,
                  density=1200, size=0.2, rmax=5, rmin=1, poses=4, rms=1.03, rms_radii=1.4756, time_s=35 * 60,
                  time="35 min"),
    "hat": dict(nodes=1727, edges=1790, rods=179, connections=116, material=948, rest=1422, E=32, nu=0.48,
                density=1200, size=0.23, rmax=3, rmin=1, poses=5, rms=1.13, rms_radii=1.3482, time_s=105 * 60,
                time="1 h 45 min"),
    "dino": dict(nodes=3219, edges=3330, rods=333, connections=222, material=1776, rest=2664, E=32, nu=0.48,
                 density=1200, size=0.20, rmax=3, rmin=1, poses=5, rms=0.56, rms_radii=0.8622, time_s=140 * 60,
                 time="2 h 20 min"),
    "smiley": dict(nodes=2663, edges=2892, rods=723, connections=494, material=2664, rest=3663, E=10, nu=0.48,
                   density=1000, size=0.25, rmax=4, rmin=1, poses=1, rms=0.41, rms_radii=None, time_s=190 * 60,
                   time="3 h 10 min"),
}


def sh(cmd):
    try:
        return subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                              cwd=ROOT).stdout.strip()
    except OSError:
        return ""


def cpu_model():
    """The processor's model name (/proc/cpuinfo), for naming the machine."""
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown CPU"


def machine():
    cpu = cpu_model()
    mem = 0
    try:
        for line in open("/proc/meminfo"):
            if line.startswith("MemTotal"):
                mem = int(line.split()[1]) / 2**20
    except OSError:
        pass
    return "%s, %d cores, %.0f GiB, %s" % (cpu, os.cpu_count() or 0, mem, platform.platform())


def text(v):
    return v.decode() if isinstance(v, bytes) else str(v)


def rms_of(f, key):
    s, n = 0.0, 0
    for name in f["poses"]:
        p = f["poses"][name]
        q, t = p[key][()], p["target"][()]
        s += float(((q - t) ** 2).sum())
        n += q.shape[0]
    return (s / n) ** 0.5


def read_run(path):
    with h5py.File(path, "r") as f:
        h = f["history"]
        hist = dict(iteration=h["iteration"][()], time=h["time_s"][()], rms=h["rms_error"][()],
                    viol=h["constraint_violation"][()], level=h["level"][()],
                    phase=np.array([text(p) for p in h["phase"][()]]))
        planar = int(f["model"].attrs.get("planar", 0))
        return dict(
            status=text(f.attrs["status"]), message=text(f.attrs.get("message", "")),
            iterations=int(f.attrs["iterations"]), time=float(f.attrs["time_s"]),
            eval=float(f.attrs.get("evaluation_time_s", np.nan)),
            solver=float(f.attrs.get("solver_time_s", np.nan)),
            memory=float(f.attrs.get("peak_memory_bytes", np.nan)),
            evaluations=int(f.attrs.get("evaluations", -1)),
            cg=int(np.sum(np.maximum(h["cg_iterations"][()], 0))) if "cg_iterations" in h else None,
            initial=rms_of(f, "initial_positions"), final=rms_of(f, "positions"),
            control_points=int(f["design/control_points/rod"].shape[0]), planar=planar,
            dofs=int(f["model"].attrs["dofs_per_pose"]),
            gap=max(float(f["poses"][n].attrs.get("equilibrium_gap", 0.0)) for n in f["poses"]),
            history=hist)


def after_radii(r):
    """RMS at the end of the radius-only levels (the last equilibrium iterate
    before the first rest-shape phase) and whether the run got that far."""
    h = r["history"]
    rest = np.where(h["phase"] == "rest_shape")[0]
    end = rest[0] if len(rest) else len(h["phase"])
    ok = np.where((h["viol"][:end] <= EQUILIBRIUM_N) & (h["phase"][:end] != "initial"))[0]
    if len(ok) == 0:
        return None, bool(len(rest))
    return float(h["rms"][ok[-1]]), bool(len(rest))


def equilibrium_curve(r):
    """(time, best RMS so far) over the iterates that are equilibria."""
    h = r["history"]
    ok = h["viol"] <= EQUILIBRIUM_N
    t, q = h["time"][ok], h["rms"][ok]
    return t, np.minimum.accumulate(q) if len(q) else q


def time_to(r, level):
    t, q = equilibrium_curve(r)
    hit = np.where(q <= level)[0]
    return float(t[hit[0]]) if len(hit) else None


def fmt_time(s):
    if s is None:
        return "–"
    if s < 100:
        return "%.1f s" % s
    if s < 3600:
        return "%.0f s (%.1f min)" % (s, s / 60)
    return "%.0f s (%.2f h)" % (s, s / 3600)


def write_csv(path, runs):
    with open(path, "w") as f:
        f.write("method,iteration,time_s,rms_mm,constraint_violation_N,is_equilibrium,phase,level\n")
        for m, r in runs.items():
            h = r["history"]
            for i in range(len(h["time"])):
                f.write("%s,%d,%.6g,%.6g,%.3g,%d,%s,%d\n" % (
                    m, h["iteration"][i], h["time"][i], 1e3 * h["rms"][i], h["viol"][i],
                    int(h["viol"][i] <= EQUILIBRIUM_N), h["phase"][i], h["level"][i]))


def plot(path, e, runs, limit):
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for m, r in runs.items():
        h = r["history"]
        ok = h["viol"] <= EQUILIBRIUM_N
        t, best = equilibrium_curve(r)
        if len(t):
            ax.step(t, 1e3 * best, where="post", color=COLOUR[m], lw=2,
                    label="%s: best equilibrium so far" % METHOD_NAME[m])
        if (~ok).any():
            ax.plot(h["time"][~ok], 1e3 * h["rms"][~ok], ".", ms=3, color=COLOUR[m], alpha=0.35,
                    label="%s: iterates off equilibrium" % METHOD_NAME[m])
        rest = np.where(h["phase"] == "rest_shape")[0]
        if len(rest):
            starts = [rest[0]] + [i for i in rest[1:] if h["phase"][i - 1] != "rest_shape"]
            ax.plot(h["time"][starts], 1e3 * h["rms"][starts], "o", mfc="white", mec=COLOUR[m], ms=6,
                    label="%s: rest-shape phase starts" % METHOD_NAME[m])
        ax.plot([r["time"]], [1e3 * r["final"]], "*", ms=13, color=COLOUR[m], mec="k",
                label="%s: final design, re-solved from rest" % METHOD_NAME[m])
    p = PAPER[e]
    ax.axhline(p["rms"], color="0.3", ls="--", lw=1, label="paper's final RMS (%.2f mm, %s)" % (p["rms"], p["time"]))
    if limit:
        ax.axvline(limit, color="0.6", ls=":", lw=1, label="time limit (%g s)" % limit)
    ax.set_yscale("log")
    ax.set_xlabel("wall time (s), one thread, machine shared")
    ax.set_ylabel("RMS error (mm)")
    ax.set_title("%s: RMS against time, %s" % (e.capitalize(), ", ".join(METHOD_NAME[m] for m in runs)))
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


SWEEPS_HEADING = "## Sweeps (benchmarks/study/sweeps.py)"


def sweeps_section(assets, rel):
    """ASSETS/sweeps.md as a section of the report (links made relative to the report, headings one level
    down), or None if there is none."""
    path = os.path.join(assets, "sweeps.md")
    if not os.path.exists(path):
        return None
    body = open(path).read()
    body = re.sub(r"\]\((?!https?:|/|#)([^)]+)\)", lambda mo: "](%s/%s)" % (rel, mo.group(1)), body)
    body = re.sub(r"^(#+) ", lambda mo: "#" + mo.group(1) + " ", body, flags=re.M)
    return SWEEPS_HEADING + "\n\n" + body.rstrip() + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes")
    ap.add_argument("--runs")
    ap.add_argument("--assets", required=True)
    ap.add_argument("--md", required=True)
    ap.add_argument("--title", default="Design study: the paper's four experiments, SAND, reduced BFGS and "
                    "reduced Newton-CG")
    ap.add_argument("--notes")
    ap.add_argument("--no-render", action="store_true")
    ap.add_argument("--command", default="benchmarks/design_study.sh")
    ap.add_argument("--update-sweeps", action="store_true",
                    help="only rewrite the sweeps section of the existing --md from ASSETDIR/sweeps.md")
    a = ap.parse_args()
    rel = os.path.relpath(a.assets, os.path.dirname(os.path.abspath(a.md)))
    if a.update_sweeps:
        old = open(a.md).read()
        sweeps = sweeps_section(a.assets, rel)
        if sweeps is None:
            ap.error("no %s" % os.path.join(a.assets, "sweeps.md"))
        i = old.find("\n" + SWEEPS_HEADING + "\n")
        new = (old[:i + 1] if i >= 0 else old.rstrip("\n") + "\n\n") + sweeps
        with open(a.md + ".tmp", "w") as f:
            f.write(new)
        os.replace(a.md + ".tmp", a.md)
        print("wrote", a.md)
        return 0
    if not (a.scenes and a.runs):
        ap.error("--scenes and --runs are required (unless --update-sweeps)")
    os.makedirs(a.assets, exist_ok=True)
    scenes = json.load(open(os.path.join(a.scenes, "scenes.json")))
    runs_meta = json.load(open(os.path.join(a.runs, "runs.json")))
    results = {}
    for e in EXPERIMENTS:
        for m in METHODS:
            path = os.path.join(a.runs, "%s_%s.h5" % (e, m))
            if os.path.exists(path) and "%s_%s" % (e, m) in runs_meta:
                r = read_run(path)
                r.update(runs_meta["%s_%s" % (e, m)])
                results.setdefault(e, {})[m] = r
    exps = [e for e in EXPERIMENTS if e in results]
    limits = sorted({r["time_limit"] for e in exps for r in results[e].values()})
    loads = [x for e in exps for r in results[e].values() for x in (r["load_before"], r["load_after"])]
    commit = sh(["git", "rev-parse", "--short", "HEAD"])
    dirty = sh(["git", "status", "--porcelain", "--untracked-files=no"])
    started = min((r["started"] for e in exps for r in results[e].values()), default="?")

    L = []
    w = L.append
    w("# %s\n" % a.title)
    w("Generated by `%s` (benchmarks/study/: make_scenes.py, run_study.py, report.py) on %s." % (
        a.command, time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())))
    run_commits = sorted({r.get("commit", "?") for e in exps for r in results[e].values()})
    w("Runs started %s at commit %s (the binary built from it); report written at commit `%s`%s; "
      "machine: %s." % (started, ", ".join("`%s`" % c for c in run_commits), commit,
                        " (with uncommitted changes)" if dirty else "", machine()))
    if loads:
        w("The machine was shared with other builds and runs: load average %.1f-%.1f (1 min) around the runs "
          "on %d cores, so wall times are upper bounds of what an idle machine gives and vary by tens of "
          "percent between repeats; each run was made once." % (min(loads), max(loads), os.cpu_count() or 0))
    schedules = sorted({r.get("schedule", "paper") for e in exps for r in results[e].values()})
    w("Every run: `rodmesh optimize SCENE --method M%s --threads 1 --time-limit %s "
      "--max-iter %s` (OPENBLAS_NUM_THREADS=1)%s. A run stopped by its time limit archives the design the "
      "optimizer holds, re-solved from rest (status `not_converged`); the paper's runs went to convergence, so where a "
      "limit stopped ours, our RMS is what that many seconds buy, not where the method ends.\n" % (
          "" if schedules == ["default"] else " --schedule %s" % "/".join(schedules),
          "/".join("%g" % x for x in limits),
          "/".join(sorted({str(r["max_iter"]) for e in exps for r in results[e].values()})),
          ": every method with its default schedule (SAND `joint`, reduced BFGS `paper`, Newton-CG `joint`)"
          if schedules == ["default"] else ""))
    w("RMS: `sqrt(sum |q - target|^2 / (poses x vertices))`. *Default*: the uniform initial design. "
      "*After radii*: the last iterate of the radius-only levels (0-2) that is an equilibrium "
      "(residual <= %g N). *Final*: the archived design (radii and rest shape), every pose re-solved "
      "by Newton from rest. Time: the optimizer's own clock (archive `time_s`); *process wall*: the "
      "whole command (start-up, equilibria of the default design, optimization, re-solves, archive). "
      "Peak memory: the process's peak resident set.\n" % EQUILIBRIUM_N)

    # ---- Table 1
    w("## Table 1, rebuilt\n")
    head = "| | " + " | ".join("%s (ours) | %s (paper)" % (e.capitalize(), e.capitalize()) for e in exps) + " |"
    w(head)
    w("|---|" + "---|---|" * len(exps))

    def row(label, ours, paper):
        w("| %s | %s |" % (label, " | ".join("%s | %s" % (ours(e), paper(e)) for e in exps)))

    any_run = {e: next(iter(results[e].values())) for e in exps}
    for key, label in [("nodes", "Nodes"), ("edges", "Edges"), ("rods", "Rods"), ("connections", "Connections")]:
        row(label, lambda e, k=key: scenes[e][k], lambda e, k=key: PAPER[e][k])
    row("Material params. (2 radii per control point)", lambda e: 2 * any_run[e]["control_points"],
        lambda e: PAPER[e]["material"])
    row("Rest-shape params. (%s per control point)" % "3, planar 2",
        lambda e: (2 if any_run[e]["planar"] else 3) * any_run[e]["control_points"], lambda e: PAPER[e]["rest"])
    row("Unknowns per pose", lambda e: any_run[e]["dofs"], lambda e: "")
    row("Poses", lambda e: len(scenes[e]["poses"]), lambda e: PAPER[e]["poses"])
    row("Young mod. (MPa)", lambda e: "%g" % (scenes[e]["young_modulus"] / 1e6), lambda e: PAPER[e]["E"])
    row("Poisson ratio", lambda e: scenes[e]["poisson_ratio"], lambda e: PAPER[e]["nu"])
    row("Density (kg/m³)", lambda e: "%g" % scenes[e]["density"], lambda e: PAPER[e]["density"])
    row("Size (m)", lambda e: scenes[e]["size_m"], lambda e: PAPER[e]["size"])
    row("Max. radius (mm)", lambda e: "%g" % (1e3 * scenes[e]["radius_bounds"][1]), lambda e: PAPER[e]["rmax"])
    row("Min. radius (mm)", lambda e: "%g" % (1e3 * scenes[e]["radius_bounds"][0]), lambda e: PAPER[e]["rmin"])
    for m in METHODS:
        def get(e, f, m=m):
            r = results[e].get(m)
            return f(r) if r else "not run"
        row("**%s** RMS default (mm)" % METHOD_NAME[m], lambda e: get(e, lambda r: "%.3f" % (1e3 * r["initial"])),
            lambda e: "")
        row("%s RMS after radii (mm)" % METHOD_NAME[m],
            lambda e: get(e, lambda r: ("%.3f" % (1e3 * after_radii(r)[0]) if after_radii(r)[0] is not None
                                        else "–") + ("" if after_radii(r)[1] else " (limit hit in radii)")),
            lambda e: "%.2f" % PAPER[e]["rms_radii"] if PAPER[e]["rms_radii"] else "")
        row("%s RMS final, radii + rest shape (mm)" % METHOD_NAME[m],
            lambda e: get(e, lambda r: "**%.3f**" % (1e3 * r["final"])), lambda e: "**%.2f**" % PAPER[e]["rms"])
        row("%s optimizer time" % METHOD_NAME[m], lambda e: get(e, lambda r: fmt_time(r["time"])),
            lambda e: PAPER[e]["time"])
        row("%s process wall time" % METHOD_NAME[m], lambda e: get(e, lambda r: fmt_time(r["wall_s"])),
            lambda e: "")
        row("%s iterations" % METHOD_NAME[m], lambda e: get(e, lambda r: r["iterations"]), lambda e: "")
        row("%s objective evaluations%s" % (METHOD_NAME[m], " (Ipopt's)" if m == "sand" else " (equilibrium solves)"),
            lambda e: get(e, lambda r: r["evaluations"] if r["evaluations"] >= 0 else "–"), lambda e: "")
        if m == "newton":
            row("%s CG iterations (Hessian-vector products)" % METHOD_NAME[m],
                lambda e: get(e, lambda r: r["cg"] if r["cg"] is not None else "–"), lambda e: "")
        row("%s peak memory (MiB)" % METHOD_NAME[m],
            lambda e: get(e, lambda r: "%.0f" % (r["peak_rss_bytes"] / 2**20)), lambda e: "")
        row("%s status" % METHOD_NAME[m], lambda e: get(e, lambda r: "%s (%s)" % (r["status"], r["message"])),
            lambda e: "")
    w("")

    # ---- RMS against time
    w("## RMS against wall time (the paper's Fig. 10, against seconds)\n")
    w("Solid steps: the best RMS among iterates that are equilibria (all of the reduced method's; SAND's "
      "once its constraints are met to %g N). Faint dots: SAND iterates off equilibrium (their RMS is "
      "not yet a design's RMS). Open circles: starts of rest-shape phases (the paper's white dots). "
      "Star: the archived design re-solved from rest. CSV columns: method, iteration, time_s, rms_mm, "
      "constraint_violation_N, is_equilibrium, phase, level.\n" % EQUILIBRIUM_N)
    for e in exps:
        plot(os.path.join(a.assets, "rms_time_%s.png" % e), e, results[e], limits[-1] if limits else None)
        write_csv(os.path.join(a.assets, "rms_time_%s.csv" % e), results[e])
        w("**%s** ([CSV](%s/rms_time_%s.csv))\n" % (e.capitalize(), rel, e))
        w("![%s RMS against time](%s/rms_time_%s.png)\n" % (e, rel, e))

    # ---- halvings
    w("## What each halving of the RMS costs\n")
    w("Time (optimizer clock) at which the best equilibrium iterate first reaches the default design's "
      "RMS divided by 2, 4, 8, ...; in brackets the time that halving took after the previous one.\n")
    K = 6
    w("| experiment | method | default RMS (mm) | " + " | ".join("/%d" % 2 ** k for k in range(1, K + 1)) + " |")
    w("|---|---|---|" + "---|" * K)
    for e in exps:
        for m, r in results[e].items():
            cells, prev = [], 0.0
            for k in range(1, K + 1):
                t = time_to(r, r["initial"] / 2 ** k)
                if t is None:
                    cells.append("–")
                    prev = None
                    continue
                cells.append("%.1f s" % t + (" (+%.1f)" % (t - prev) if prev is not None and k > 1 else ""))
                prev = t
            w("| %s | %s | %.3f | %s |" % (e, METHOD_NAME[m], 1e3 * r["initial"], " | ".join(cells)))
    w("")

    # ---- against the paper
    w("## Against the paper\n")
    w("The paper's times are to convergence on an Intel i7 4770K (2013); ours are on the machine above, "
      "one thread, loaded. *Time to the paper's RMS*: when our best equilibrium iterate first gets as low "
      "as the paper's final RMS for that experiment (our targets are made by rodmesh, not the paper's "
      "thin-shell/FEM/artist targets, so equal RMS is a yardstick, not the same problem).\n")
    w("| experiment | paper: RMS, time | method | our final RMS (mm) | our time | time to the paper's RMS "
      "| paper time / ours |")
    w("|---|---|---|---|---|---|---|")
    for e in exps:
        p = PAPER[e]
        for m, r in results[e].items():
            t = time_to(r, p["rms"] * 1e-3)
            speed = "%.0fx" % (p["time_s"] / t) if t else "not reached within the run"
            w("| %s | %.2f mm, %s | %s | %.3f | %s | %s | %s |" % (
                e, p["rms"], p["time"], METHOD_NAME[m], 1e3 * r["final"], fmt_time(r["time"]),
                fmt_time(t), speed))
    w("")

    # ---- which method wins
    w("## Which method wins where (from these runs)\n")
    for e in exps:
        rs = results[e]
        if len(rs) < 2:
            continue
        ms = sorted(rs, key=lambda m: rs[m]["final"])
        horizon = min(r["time"] for r in rs.values())
        at = {}
        for m, r in rs.items():
            t, q = equilibrium_curve(r)
            k = np.where(t <= horizon)[0]
            at[m] = 1e3 * q[k[-1]] if len(k) else float("nan")
        parts = []
        for m in ms:
            r = rs[m]
            share = ("%.0f%% in Ipopt/MUMPS" % (100 * r["solver"] / max(r["time"], 1e-9)) if m == "sand" else
                     "%d equilibrium solves" % r["evaluations"] if r["evaluations"] >= 0 else "")
            parts.append("%s %.3f mm (%s, %s, %d iterations%s%s)" % (
                METHOD_NAME[m], 1e3 * r["final"], r["status"], fmt_time(r["time"]), r["iterations"],
                ", " + share if share else "",
                ", %d CG iterations" % r["cg"] if m == "newton" and r["cg"] is not None else ""))
        w("- **%s**: final RMS, lowest first: %s. Best equilibrium at %.0f s (the shortest run's end): %s." % (
            e.capitalize(), "; ".join(parts), horizon,
            ", ".join("%s %.3f mm" % (METHOD_NAME[m], at[m]) for m in ms)))
    w("")

    # ---- pictures
    w("## Pictures (the paper's Figs. 6-9)\n")
    w("`scripts/render.py ARCHIVE -o FIG.png` on each archive: per pose the target (translucent grey), the "
      "default design's equilibrium (red, dashed) and the optimized design's (green); last panel: the "
      "rest shape coloured by r_n (mm).\n")
    for e in exps:
        for m in results[e]:
            png = "render_%s_%s.png" % (e, m)
            if not a.no_render:
                subprocess.run([sys.executable, os.path.join(ROOT, "scripts", "render.py"),
                                os.path.join(a.runs, "%s_%s.h5" % (e, m)), "-o", os.path.join(a.assets, png),
                                "--dpi", "75"] + (["--view", "top", "--panel-size", "7"] if e == "smiley" else []), check=True)
            w("**%s, %s** (final RMS %.3f mm)\n" % (e.capitalize(), METHOD_NAME[m], 1e3 * results[e][m]["final"]))
            w("![%s %s](%s/%s)\n" % (e, m, rel, png))

    # ---- scenes
    w("## The scenes\n")
    w("`benchmarks/study/make_scenes.py` (docstring: supports, loads and designs of every pose). Target "
      "poses and the largest displacement of a vertex from rest:\n")
    for e in exps:
        w("- %s: %s" % (e.capitalize(), "; ".join(
            "%s %.1f mm" % (p["name"], p["max_displacement_mm"]) + (
                " (default design sags %.2f mm)" % p["default_design_sag_mm"] if "default_design_sag_mm" in p
                else "") + (" (pulled by %.1f N, chosen so that the default design stretches %.1f mm like the "
                            "drawn target)" % (p["pulling_force_N"], p["target_right_side_mm"])
                            if "pulling_force_N" in p else "")
            for p in scenes[e]["poses"])))
    w("")

    if a.notes and os.path.exists(a.notes):
        w(open(a.notes).read().rstrip() + "\n")
    sweeps = sweeps_section(a.assets, rel)
    if sweeps:
        w(sweeps)
    with open(a.md + ".tmp", "w") as f:
        f.write("\n".join(L))
    os.replace(a.md + ".tmp", a.md)
    print("wrote", a.md)
    return 0


if __name__ == "__main__":
    sys.exit(main())
