#!/usr/bin/env python3
"""Accuracy against time, discretization, the paper's finite-difference recipe
against exact derivatives, scaling, and the paper's Table 2 (issue #10).

usage: /usr/bin/python3 benchmarks/study/sweeps.py --rodmesh BIN --out OUTDIR [--quick] [--only PART ...]

Parts (PARTS below): tolerance, discretization, fd, scaling (time per
iteration against poses and vertices, one thread), threads (1 against 2
threads: run it on an otherwise idle machine), table2. Parts run separately
(`--only`) into separate OUTDIRs are merged by merge_sweeps.py.

Runs everything through the rodmesh CLI, reads the archives with h5py and
writes OUTDIR/*.csv, OUTDIR/*.png and OUTDIR/sweeps.md. Every optimize run
is bounded by --max-iter and --time-limit (table LIMITS below), every
relaxation solve by --time-limit; --quick keeps the whole study to a few
minutes on small sheets, the full mode uses the paper's Sheet and larger
sheets. Scenes are generated into a temporary directory (see
sweeps_scenes.py for the hidden designs that make the targets).
"""
import argparse
import csv
import datetime
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time

os.environ.setdefault("MPLBACKEND", "Agg")
import h5py  # noqa: E402
import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import sweeps_scenes as S  # noqa: E402
from report import cpu_model  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))

# Per mode: sheets (hex cells, vertices per rod), iteration caps and time limits (s).
LIMITS = {
    True: dict(  # --quick
        sheet=(3, 3, 11), tol_sheet=(2, 2, 7), tol_iter=5000, tol_time=12, tols=[1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8],
        disc_cells=(3, 3), disc_k=[5, 7, 11, 21], disc_fine=61, disc_iter=200, disc_time=90,
        fd_iter=400, fd_time=25, fdr_sheet=(2, 2, 5), fdr_iter=6, fdr_time=30,
        poses=[1, 2, 4, 8], scale_iter=8, scale_time=20,
        vert_cells=[(2, 2), (3, 3), (5, 4), (6, 6), (9, 8), (13, 13)], vert_iter=4, vert_time=40,
        threads_poses=4, t2_duration=0.2, t2_relax_time=10, paper_sheet=False),
    False: dict(  # full
        sheet=None, tol_sheet=(3, 3, 11), tol_iter=10000, tol_time=90, tols=[1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8],
        disc_cells=(4, 5), disc_k=[5, 7, 11, 13, 21], disc_fine=61, disc_iter=400, disc_time=600,
        fd_iter=3000, fd_time=300, fdr_sheet=(3, 3, 6), fdr_iter=6, fdr_time=200,
        poses=[1, 2, 3, 4, 6, 8], scale_iter=10, scale_time=120,
        vert_cells=[(2, 2), (3, 3), (5, 4), (6, 6), (9, 8), (13, 13), (18, 18), (26, 26)], vert_iter=4,
        vert_time=300, threads_poses=8, t2_duration=1.0, t2_relax_time=120, paper_sheet=True),
}

# The paper's Table 2 (Perez et al. 2015; Intel i7 4470K): N, dt (s), t (ms), T (s).
PAPER_T2 = {"Hat": (6971, 0.0078, 62.956, 21.06), "Dinosaur": (12987, 0.0138, 108.78, 19.321),
            "Sphere": (10076, 0.0082, 118.40, 45.321)}


# The parts, in the order they run: name -> Study method. `threads` (1 against 2 threads) wants an idle machine.
PARTS = {"tolerance": "tolerance", "discretization": "discretization", "fd": "fd_vs_exact", "scaling": "scaling",
         "threads": "threads", "table2": "table2"}


def fmt(x, d=3):
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "—"
    if isinstance(x, (int, np.integer)):
        return str(x)
    if x == 0:
        return "0"
    a = abs(x)
    if a >= 1e4 or a < 1e-3:
        return "%.*e" % (d - 1, x)
    return "%.*g" % (d, x)


def write_csv(path, rows):
    if not rows:
        return
    keys = list(rows[0].keys())
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        for r in rows:
            w.writerow({k: r.get(k) for k in keys})


def table(header, rows):
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(str(c).replace("|", "\\|") for c in r) + " |" for r in rows]
    return "\n".join(out)


def fit_exponent(x, y):
    """Least-squares slope of log y against log x."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = (x > 0) & (y > 0) & np.isfinite(y)
    if ok.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(x[ok]), np.log(y[ok]), 1)[0])


def per_iteration(r):
    """Median wall time of one optimizer iteration (history time differences,
    the initial equilibria excluded)."""
    t = np.asarray(r["hist_t"], float)
    d = np.diff(t)
    return float(np.median(d)) if len(d) else float("nan")


def time_to_reach(r, level):
    """First history time at which the RMS is <= level (None if never)."""
    for t, e in zip(r["hist_t"], r["hist_rms"]):
        if e <= level:
            return float(t)
    return None


class Study:
    def __init__(self, args):
        self.bin = os.path.abspath(args.rodmesh)
        self.out = os.path.abspath(args.out)
        self.quick = args.quick
        self.only = args.only
        self.L = LIMITS[args.quick]
        os.makedirs(self.out, exist_ok=True)
        self.tmp = tempfile.mkdtemp(prefix="rodmesh_sweeps_")
        self.md = []
        self.t0 = time.perf_counter()
        self.started = datetime.datetime.utcnow()
        # The code that runs: the commit at the start, and whether tracked files differed from it.
        try:
            commit = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], stdout=subprocess.PIPE,
                                    text=True).stdout.strip()
            dirty = subprocess.run(["git", "-C", ROOT, "status", "--porcelain", "--untracked-files=no"],
                                   stdout=subprocess.PIPE, text=True).stdout.strip()
        except OSError:
            commit, dirty = "unknown", ""
        self.commit = (commit, dirty)
        self.parts = []

    def path(self, name):
        return os.path.join(self.tmp, name)

    def log(self, msg):
        print("[%6.0f s] %s" % (time.perf_counter() - self.t0, msg), file=sys.stderr, flush=True)

    def limits(self, it, tl):
        return ["--max-iter", str(it), "--time-limit", str(tl)]

    # -- scenes -------------------------------------------------------------
    def sheet(self, name, cells, k, poses=2):
        p = self.path(name + ".json")
        base = S.hex_sheet(self.bin, self.path(name + ".base.json"), cells, k, pulls=S.POSE_LOADS[:poses])
        S.with_targets(self.bin, base, p)
        return p

    def paper_sheet(self):
        p = self.path("paper_sheet.json")
        if not os.path.exists(p):
            S.run(["/usr/bin/python3", os.path.join(ROOT, "benchmarks", "design_sheet.py"), self.bin, p])
        return p

    def main_sheet(self):
        """The sheet of the tolerance and fd sweeps: the paper's Sheet (full) or a small hex sheet (quick)."""
        if self.L["paper_sheet"]:
            return self.paper_sheet(), "the paper's Sheet (benchmarks/design_sheet.py: 693 vertices, 4 poses)"
        nx, ny, k = self.L["sheet"]
        p = self.sheet("small", (nx, ny), k)
        s = json.load(open(p))
        return p, "hex sheet %dx%d cells, %d vertices per rod (%d vertices, %d rods, 2 poses, hidden-design targets)" % (
            nx, ny, k, len(s["vertices"]), len(s["rods"]))

    # -- 1. tolerance -------------------------------------------------------
    def tolerance(self):
        nx, ny, k = self.L["tol_sheet"]
        scene = self.sheet("tol", (nx, ny), k)
        s = json.load(open(scene))
        desc = "hex sheet %dx%d cells, K = %d (%d vertices, %d rods), 2 poses, hidden-design targets" % (
            nx, ny, k, len(s["vertices"]), len(s["rods"]))
        rows, runs = [], {}
        for method in ("reduced", "sand", "newton"):
            for tol in self.L["tols"]:
                self.log("tolerance: %s --tol %g" % (method, tol))
                out = self.path("tol_%s_%g.h5" % (method, tol))
                try:
                    r = S.optimize(self.bin, scene, out, ["--method", method, "--tol", str(tol), "--schedule", "joint"] +
                                   self.limits(self.L["tol_iter"], self.L["tol_time"]))
                except S.RunError as e:
                    self.log(str(e))
                    continue
                runs[(method, tol)] = r
                rows.append(dict(method=method, tol=tol, status=r["status"], iterations=r["iterations"],
                                 time_s=r["time_s"], rms_mm=r["rms"] * 1e3, residual_N=r["residual"],
                                 equilibrium_gap_m=r["gap"], last_violation_N=r["last_violation"],
                                 process_wall_s=r["wall_s"], process_cpu_s=r["cpu_s"], message=r["message"]))
        write_csv(os.path.join(self.out, "tolerance.csv"), rows)
        fig, ax = plt.subplots(1, 2, figsize=(11, 4))
        for (method, tol), r in runs.items():
            ax[0].semilogy(r["hist_t"], np.asarray(r["hist_rms"]) * 1e3,
                           {"reduced": "-", "sand": "--", "newton": ":"}[method],
                           label="%s %g" % (method, tol))
        ax[0].set_xlabel("time (s)")
        ax[0].set_ylabel("RMS error (mm)")
        ax[0].legend(fontsize=6, ncol=2)
        for method, mk in (("reduced", "o-"), ("sand", "s--"), ("newton", "^:")):
            rr = [x for x in rows if x["method"] == method]
            if rr:
                ax[1].loglog([x["tol"] for x in rr], [x["time_s"] for x in rr], mk, label=method + " time (s)")
                ax[1].loglog([x["tol"] for x in rr], [x["rms_mm"] for x in rr], mk, alpha=0.5,
                             label=method + " RMS (mm)")
        ax[1].set_xlabel("--tol")
        ax[1].invert_xaxis()
        ax[1].legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(os.path.join(self.out, "tolerance.png"), dpi=110)
        plt.close(fig)
        md = ["## Tolerance sweep", "",
              "Scene: %s. `rodmesh optimize --schedule joint --tol X --max-iter %d --time-limit %d` for each "
              "method (joint: one phase, so that the tolerance, not the paper schedule's per-phase caps and "
              "round rule, decides when the reduced method stops); RMS over all "
              "poses and vertices of the archived positions (re-solved from rest under the final design); "
              "residual: largest archived force residual of those re-solves; gap: largest distance between the "
              "optimizer's own positions and the re-solve (the equilibrium error of the optimizer's iterate); "
              "violation: the optimizer's last equilibrium violation (SAND; 0 for reduced)." %
              (desc, self.L["tol_iter"], self.L["tol_time"]), "",
              table(["method", "--tol", "status", "iterations", "time (s)", "CPU (s)", "RMS (mm)", "residual (N)",
                     "gap (m)", "violation (N)", "stopped because"],
                    [[x["method"], "%g" % x["tol"], x["status"], x["iterations"], fmt(x["time_s"]),
                      fmt(x["process_cpu_s"]), fmt(x["rms_mm"], 4),
                      fmt(x["residual_N"], 2), fmt(x["equilibrium_gap_m"], 2), fmt(x["last_violation_N"], 2),
                      x["message"][:70]] for x in rows]),
              "", "![tolerance](tolerance.png)", ""]
        self.md += md
        self.tol_rows = rows

    # -- 2. discretization --------------------------------------------------
    def discretization(self):
        cells, kf = self.L["disc_cells"], self.L["disc_fine"]
        fine_base = S.hex_sheet(self.bin, self.path("disc_fine.base.json"), cells, kf, pulls=S.POSE_LOADS[:2])
        fine = S.with_targets(self.bin, fine_base, self.path("disc_fine.json"))
        targets = {p["name"]: np.asarray(p["target"]) for p in fine["poses"]}
        Vf = np.asarray(fine["vertices"])

        def fine_rms(radii, rest):
            s = dict(fine)
            s["vertices"] = rest.tolist()
            s["radii"] = radii.tolist()
            s.pop("radius", None)
            s.pop("design", None)
            pos = S.simulate(self.bin, s, self.path("disc_check.json"))
            e = sum(float(((pos[n] - targets[n]) ** 2).sum()) for n in targets)
            return math.sqrt(e / (len(targets) * len(Vf)))

        uniform = fine_rms(np.full((len(Vf), 2), 0.002), Vf)
        rows, runs = [], {}
        for k in self.L["disc_k"]:
            if (kf - 1) % (k - 1):
                raise SystemExit("discretization: fine K - 1 = %d is not a multiple of K - 1 = %d" % (kf - 1, k - 1))
            self.log("discretization: K = %d" % k)
            base = S.hex_sheet(self.bin, self.path("disc_%d.base.json" % k), cells, k, pulls=S.POSE_LOADS[:2])
            if not S.same_rods(base, fine):
                raise SystemExit("discretization: the K = %d sheet's rods differ from the fine sheet's" % k)
            # Targets: the fine targets at the coarse vertices (a subset of the fine ones, as (kf-1) % (k-1) == 0).
            Vc = np.asarray(base["vertices"])
            idx = [int(np.argmin(np.linalg.norm(Vf - v, axis=1))) for v in Vc]
            assert max(np.linalg.norm(Vf[idx] - Vc, axis=1)) < 1e-9
            sc = dict(base)
            sc["radius"] = [0.002, 0.002]
            sc["poses"] = [dict(p, target=targets[p["name"]][idx].tolist()) for p in base["poses"]]
            sc["design"] = dict(parameters=["radii", "rest_shape"], radius_bounds=[0.001, 0.005],
                                control_points_per_rod=4)
            sp = self.path("disc_%d.json" % k)
            json.dump(sc, open(sp, "w"))
            out = self.path("disc_%d.h5" % k)
            r = S.optimize(self.bin, sp, out, ["--method", "reduced", "--schedule", "joint"] +
                           self.limits(self.L["disc_iter"], self.L["disc_time"]))
            runs[k] = r
            scene, polys = S.control_polygon(out)
            # The transfer reproduces the archived design at its own K ...
            rad_c, rest_c = S.apply_design(polys, scene)
            with h5py.File(out) as f:
                err = max(abs(rad_c - f["design/radii"][()]).max(), abs(rest_c - f["rest/positions"][()]).max())
            if err > 1e-12:
                raise SystemExit("discretization: control-point transfer does not reproduce the archive (%g)" % err)
            # ... and gives the design at the fine K.
            rad_f, rest_f = S.apply_design(polys, fine)
            rf = fine_rms(rad_f, rest_f)
            rows.append(dict(k=k, vertices=len(Vc), dofs=r["dofs"], status=r["status"], iterations=r["iterations"],
                             time_s=r["time_s"], process_wall_s=r["wall_s"], process_cpu_s=r["cpu_s"],
                             per_iteration_s=per_iteration(r), rms_own_mm=r["rms"] * 1e3,
                             rms_fine_mm=rf * 1e3, uniform_fine_mm=uniform * 1e3))
        write_csv(os.path.join(self.out, "discretization.csv"), rows)
        fig, ax = plt.subplots(1, 2, figsize=(11, 4))
        ks = [x["k"] for x in rows]
        ax[0].plot(ks, [x["rms_own_mm"] for x in rows], "o-", label="RMS at K (optimizer's own)")
        ax[0].plot(ks, [x["rms_fine_mm"] for x in rows], "s-", label="RMS re-simulated at K = %d" % kf)
        ax[0].set_xlabel("vertices per rod K")
        ax[0].set_ylabel("RMS error (mm)")
        ax[0].set_yscale("log")
        ax[0].legend(fontsize=8)
        for k, r in runs.items():
            ax[1].semilogy(r["hist_t"], np.asarray(r["hist_rms"]) * 1e3, label="K = %d" % k)
        ax[1].set_xlabel("time (s)")
        ax[1].set_ylabel("RMS at K (mm)")
        ax[1].legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(os.path.join(self.out, "discretization.png"), dpi=110)
        plt.close(fig)
        nv = len(Vf)
        self.md += [
            "## Discretization sweep", "",
            "Hex sheet %dx%d cells (%d rods), left side held, gravity, 2 pulled poses. Targets: equilibria of a "
            "hidden design (radii and a vertical rest displacement, smooth functions of position: "
            "`sweeps_scenes.hidden_design`) simulated at the fine discretization K = %d (%d vertices). At each "
            "coarse K the targets are the fine targets at the coarse vertices (they are a subset, as K_fine - 1 "
            "is a multiple of K - 1). The design optimized at K (`--method reduced --schedule joint`, radii and rest shape, the same "
            "iteration budget at every K: `--max-iter %d --time-limit %d`) is moved to the fine sheet through its archived control points "
            "(`/design/control_points`: per rod, Bernstein control values at arc fractions; they do not depend on "
            "K — the script checks that the transfer reproduces the archived per-vertex design at K to 1e-12) "
            "and re-simulated there from rest; RMS fine is against the fine targets at all %d fine vertices. "
            "Uniform 2 mm design at K = %d: RMS %s mm." % (cells[0], cells[1], len(fine["rods"]), kf, nv,
                                                            self.L["disc_iter"], self.L["disc_time"], nv, kf,
                                                            fmt(uniform * 1e3, 4)), "",
            table(["K", "vertices", "unknowns/pose", "status", "iterations", "time (s)", "CPU (s)", "s/iteration",
                   "RMS at K (mm)", "RMS at K = %d (mm)" % kf],
                  [[x["k"], x["vertices"], x["dofs"], x["status"], x["iterations"], fmt(x["time_s"]),
                    fmt(x["process_cpu_s"]),
                    fmt(x["per_iteration_s"]), fmt(x["rms_own_mm"], 4), fmt(x["rms_fine_mm"], 4)] for x in rows]),
            "",
            "The fine RMS falls with the edge count per rod as (K - 1)^%.2f (least squares over the rows above); "
            "the excess of the fine RMS over the RMS at K, sqrt(fine^2 - own^2), is what the coarse "
            "discretization itself costs: %s." % (
                fit_exponent([x["k"] - 1 for x in rows], [x["rms_fine_mm"] for x in rows]),
                ", ".join("K = %d: %s mm" % (x["k"], fmt(math.sqrt(max(x["rms_fine_mm"] ** 2 - x["rms_own_mm"] ** 2,
                                                                        0.0)), 3)) for x in rows)),
            "", "![discretization](discretization.png)", ""]
        self.disc_rows = rows

    # -- 3. finite differences against exact --------------------------------
    def fd_vs_exact(self):
        scene, desc = self.main_sheet()
        runs = {}
        for mode in ("exact", "fd"):
            self.log("fd vs exact: %s" % mode)
            runs[mode] = S.optimize(self.bin, scene, self.path("fd_%s.h5" % mode),
                                    ["--method", "reduced", "--design-derivatives", mode] +
                                    self.limits(self.L["fd_iter"], self.L["fd_time"]))
        nx, ny, k = self.L["fdr_sheet"]
        tiny = self.sheet("fdr", (nx, ny), k)
        ts = json.load(open(tiny))
        tiny_runs = {}
        for mode in ("exact", "fd", "fd-resolve"):
            self.log("fd vs exact (tiny sheet): %s" % mode)
            tiny_runs[mode] = S.optimize(self.bin, tiny, self.path("fdr_%s.h5" % mode),
                                         ["--method", "reduced", "--schedule", "joint", "--design-derivatives",
                                          mode] + self.limits(self.L["fdr_iter"], self.L["fdr_time"]))
        rows = []
        for label, rs in (("main", runs), ("tiny", tiny_runs)):
            for mode, r in rs.items():
                ph = np.asarray(r["hist_phase"]) if r["hist_phase"] is not None else None
                d = np.diff(np.asarray(r["hist_t"]))
                lv = np.asarray(r["hist_level"])[1:]
                per = {}
                for key, sel in (("radii_l0", (ph[1:] == "radii") & (lv == 0)),
                                 ("radii_l2", (ph[1:] == "radii") & (lv == 2)),
                                 ("rest_shape", ph[1:] == "rest_shape")):
                    per[key] = float(np.median(d[sel])) if sel.any() else float("nan")
                rows.append(dict(scene=label, mode=mode, status=r["status"], iterations=r["iterations"],
                                 time_s=r["time_s"], rms_mm=r["rms"] * 1e3, per_iteration_s=per_iteration(r),
                                 per_it_radii_l0_s=per["radii_l0"], per_it_radii_l2_s=per["radii_l2"],
                                 per_it_rest_s=per["rest_shape"]))
        write_csv(os.path.join(self.out, "fd_vs_exact.csv"), rows)
        # Time to the same RMS: the larger of the two final RMS values, reached by both.
        e, f = runs["exact"], runs["fd"]
        n_common = min(len(e["hist_rms"]), len(f["hist_rms"]))
        path_diff = float(np.max(np.abs(np.asarray(f["hist_rms"][:n_common]) /
                                        np.asarray(e["hist_rms"][:n_common]) - 1)))
        common = max(min(e["hist_rms"]), min(f["hist_rms"]))
        te, tf = time_to_reach(e, common), time_to_reach(f, common)
        # Halvings of the RMS from the initial design, both recipes.
        halv = []
        r0 = e["hist_rms"][0]
        for h in range(0, 12):
            lvl = r0 / 2 ** h
            a, b = time_to_reach(e, lvl), time_to_reach(f, lvl)
            if a is None and b is None:
                break
            halv.append(dict(halvings=h, rms_mm=lvl * 1e3, exact_s=a, fd_s=b))
        for i, x in enumerate(halv):
            for m in ("exact", "fd"):
                prev = halv[i - 1]["%s_s" % m] if i else None
                cur = x["%s_s" % m]
                x["%s_cost_s" % m] = cur - prev if (cur is not None and prev is not None) else None
        write_csv(os.path.join(self.out, "halvings.csv"), halv)
        fig, ax = plt.subplots(1, 2, figsize=(11, 4))
        for mode, r in runs.items():
            ax[0].semilogy(r["hist_t"], np.asarray(r["hist_rms"]) * 1e3, label=mode)
        ax[0].set_xlabel("time (s)")
        ax[0].set_ylabel("RMS error (mm)")
        ax[0].set_title("main sheet", fontsize=9)
        ax[0].legend()
        for mode, r in tiny_runs.items():
            ax[1].semilogy(r["hist_t"], np.asarray(r["hist_rms"]) * 1e3, "o-", ms=3, label=mode)
        ax[1].set_xlabel("time (s)")
        ax[1].set_title("tiny sheet", fontsize=9)
        ax[1].legend()
        fig.tight_layout()
        fig.savefig(os.path.join(self.out, "fd_vs_exact.png"), dpi=110)
        plt.close(fig)
        nvar = "392 radii + 588 rest-shape variables at the finest level" if self.L["paper_sheet"] else ""
        self.md += [
            "## The paper's recipe against ours: finite-difference design derivatives", "",
            "`--method reduced --design-derivatives exact|fd|fd-resolve`. `exact`: adjoint gradient with exact "
            "dF/dp (AD). `fd`: the paper's recipe (§4.2): dF/dz by central differences of the forces at the "
            "fixed equilibrium, one pair of force evaluations per pose and design variable, no re-solve. "
            "`fd-resolve`: central differences of the objective, every probe re-solving every pose by Newton "
            "from the current equilibrium (2 x variables x poses Newton solves per gradient). Main scene: %s%s; "
            "`--max-iter %d --time-limit %d`. Tiny scene: hex sheet %dx%d cells, K = %d (%d vertices), "
            "`--schedule joint --max-iter %d --time-limit %d` (every radius and displacement free from the start: "
            "the most variables, the worst case for finite differences). s/iteration is the median wall time of one optimizer iteration "
            "(gradient and line search); by phase: radii at level 0 (rod ends only), radii at level 2 (all "
            "control points), rest shape." % (desc, (" (" + nvar + ")") if nvar else "", self.L["fd_iter"],
                                              self.L["fd_time"], nx, ny, k, len(ts["vertices"]),
                                              self.L["fdr_iter"], self.L["fdr_time"]), "",
            table(["scene", "derivatives", "status", "iterations", "time (s)", "RMS (mm)", "s/iteration",
                   "radii L0", "radii L2", "rest shape"],
                  [[x["scene"], x["mode"], x["status"], x["iterations"], fmt(x["time_s"]), fmt(x["rms_mm"], 4),
                    fmt(x["per_iteration_s"]), fmt(x["per_it_radii_l0_s"]), fmt(x["per_it_radii_l2_s"]),
                    fmt(x["per_it_rest_s"])] for x in rows]), "",
            "Over the first %d iterations (as far as both runs went) the RMS of the two runs at equal "
            "iteration numbers differs by at most %.1e relative: %s" % (
                n_common - 1, path_diff,
                "the finite-difference gradient follows the exact method's path, only slower." if path_diff < 1e-3
                else "the paths drift apart (BFGS and its line search amplify the small gradient differences over "
                     "many iterations), so the time to a given RMS differs from the ratio of times per iteration."),
            "",
            "Same RMS (%s mm, the higher of the two runs' best): exact after %s s, fd after %s s (%s)." % (
                fmt(common * 1e3, 4), fmt(te), fmt(tf),
                ("fd takes %.1fx as long" % (tf / te)) if (te and tf) else "one run never reached it"), "",
            "### What each halving of the RMS costs", "",
            "Main scene, from the runs above: time at which the RMS first fell to the initial RMS / 2^h, and the "
            "time that halving took.", "",
            table(["h", "RMS (mm)", "exact: reached (s)", "exact: cost (s)", "fd: reached (s)", "fd: cost (s)"],
                  [[x["halvings"], fmt(x["rms_mm"], 4), fmt(x["exact_s"]), fmt(x["exact_cost_s"]), fmt(x["fd_s"]),
                    fmt(x["fd_cost_s"])] for x in halv]), "",
            "![fd vs exact](fd_vs_exact.png)", ""]
        self.fd_rows, self.halv = rows, halv

    # -- 4. scaling ---------------------------------------------------------
    def scaling_row(self, sweep, r, poses, threads, cells):
        """One row of the scaling and threads tables. s/iteration needs at least 2 iterations (else NaN);
        CPU per iteration is estimated as s/iteration x the process's CPU time / its wall time (on a loaded
        machine the process waits for a core part of its wall time)."""
        per = per_iteration(r) if r["iterations"] >= 2 else float("nan")
        load = r["cpu_s"] / r["wall_s"] if r["wall_s"] > 0 else float("nan")
        return dict(sweep=sweep, cells="%dx%d" % tuple(cells), poses=poses, vertices=r["n_vertices"], dofs=r["dofs"], threads=threads,
                    iterations=r["iterations"], per_iteration_s=per, cpu_per_iteration_s=per * load,
                    initial_s=float(r["hist_t"][0]) if len(r["hist_t"]) else float("nan"), time_s=r["time_s"],
                    process_wall_s=r["wall_s"], process_cpu_s=r["cpu_s"], cpu_over_wall=load,
                    peak_mib=r["peak_mib"], status=r["status"], message=r["message"])

    def scaling(self):
        nx, ny, k = self.L["sheet"] or (4, 5, 11)
        rows = []
        for n in self.L["poses"]:
            self.log("scaling: %d poses" % n)
            p = self.sheet("poses_%d" % n, (nx, ny), k, poses=n)
            r = S.optimize(self.bin, p, self.path("poses_%d.h5" % n),
                           ["--method", "reduced", "--schedule", "joint", "--threads", "1"] +
                           self.limits(self.L["scale_iter"], self.L["scale_time"]))
            rows.append(self.scaling_row("poses", r, n, 1, (nx, ny)))
        vt = self.L["vert_time"]
        vt = vt if isinstance(vt, (list, tuple)) else [vt] * len(self.L["vert_cells"])
        for cells, tl in zip(self.L["vert_cells"], vt):
            self.log("scaling: cells %s" % (cells,))
            p = self.sheet("verts_%d_%d" % cells, cells, 11, poses=2)
            r = S.optimize(self.bin, p, self.path("verts_%d_%d.h5" % cells),
                           ["--method", "reduced", "--schedule", "joint", "--threads", "1"] +
                           self.limits(self.L["vert_iter"], tl))
            rows.append(self.scaling_row("vertices", r, 2, 1, cells))
            self.log("scaling: %d vertices, %d iterations, %s s/iteration, %.0f s wall, %.0f s CPU" % (
                r["n_vertices"], r["iterations"], fmt(rows[-1]["per_iteration_s"]), r["wall_s"], r["cpu_s"]))
        write_csv(os.path.join(self.out, "scaling.csv"), rows)
        P = [x for x in rows if x["sweep"] == "poses"]
        V = [x for x in rows if x["sweep"] == "vertices"]
        ep = fit_exponent([x["poses"] for x in P], [x["per_iteration_s"] for x in P])
        ev = fit_exponent([x["vertices"] for x in V], [x["per_iteration_s"] for x in V])
        epc = fit_exponent([x["poses"] for x in P], [x["cpu_per_iteration_s"] for x in P])
        evc = fit_exponent([x["vertices"] for x in V], [x["cpu_per_iteration_s"] for x in V])
        em = fit_exponent([x["vertices"] for x in V], [x["peak_mib"] for x in V])
        Vm = [x for x in V if math.isfinite(x["per_iteration_s"])]
        vrange = (min(x["vertices"] for x in Vm), max(x["vertices"] for x in Vm)) if Vm else (0, 0)
        # The upper half of the vertex range alone (where the fixed costs no longer dominate).
        Vh = sorted(Vm, key=lambda x: x["vertices"])[len(Vm) // 2:]
        evh = fit_exponent([x["vertices"] for x in Vh], [x["per_iteration_s"] for x in Vh])
        short = [x for x in rows if not math.isfinite(x["per_iteration_s"])]
        fig, ax = plt.subplots(1, 2, figsize=(11, 4))
        ax[0].loglog([x["poses"] for x in P], [x["per_iteration_s"] for x in P], "o-", label="wall")
        ax[0].loglog([x["poses"] for x in P], [x["cpu_per_iteration_s"] for x in P], "s--", label="CPU (est.)")
        ax[0].set_xlabel("poses")
        ax[0].set_ylabel("s per iteration")
        ax[0].set_title("exponent %.2f (wall), %.2f (CPU)" % (ep, epc), fontsize=9)
        ax[0].legend(fontsize=8)
        ax[1].loglog([x["vertices"] for x in V], [x["per_iteration_s"] for x in V], "o-", label="wall")
        ax[1].loglog([x["vertices"] for x in V], [x["cpu_per_iteration_s"] for x in V], "s--", label="CPU (est.)")
        ax[1].set_xlabel("vertices")
        ax[1].set_title("exponent %.2f (wall), %.2f (CPU)" % (ev, evc), fontsize=9)
        ax[1].legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(os.path.join(self.out, "scaling.png"), dpi=110)
        plt.close(fig)
        self.md += [
            "## Scaling: time per iteration against poses and vertices", "",
            "`--method reduced --schedule joint --threads 1` (every variable at the finest level, so every "
            "iteration is alike); time per iteration = median over the run's iterations of the history's time "
            "differences (gradient: one Newton solve per pose and the adjoint solves, plus the line search's "
            "probes; the initial equilibria excluded, their time is the *initial* column); runs with fewer than "
            "2 iterations have no time per iteration. CPU: user + system time of the rodmesh process "
            "(getrusage); CPU per iteration is estimated as s/iteration x the process's CPU/wall ratio. Poses: "
            "hex sheet %dx%d cells, K = %d, 1 to %d poses (`--max-iter %d --time-limit %d`). Vertices: hex "
            "sheets with K = 11, 2 poses (`--max-iter %d --time-limit %s`). Fitted exponents: least squares of "
            "log(time) against log(size). The 1-against-2-threads comparison is its own part (`--only threads`)."
            % (nx, ny, k, max(self.L["poses"]), self.L["scale_iter"], self.L["scale_time"], self.L["vert_iter"],
               "/".join(str(t) for t in sorted(set(vt)))), "",
            table(["sweep", "cells", "poses", "vertices", "unknowns/pose", "iterations", "initial (s)",
                   "s/iteration", "CPU s/iteration (est.)", "process wall (s)", "process CPU (s)",
                   "peak memory (MiB)"],
                  [[x["sweep"], x["cells"], x["poses"], x["vertices"], x["dofs"], x["iterations"],
                    fmt(x["initial_s"]), fmt(x["per_iteration_s"]), fmt(x["cpu_per_iteration_s"]),
                    fmt(x["process_wall_s"]), fmt(x["process_cpu_s"]), fmt(x["peak_mib"])] for x in rows]), "",
            "Fitted exponents: time per iteration ~ poses^%.2f (CPU estimate: ^%.2f); ~ vertices^%.2f (CPU "
            "estimate: ^%.2f) over %d to %d vertices, ^%.2f over the upper half of that range (%d to %d); peak "
            "memory ~ vertices^%.2f.%s" % (
                ep, epc, ev, evc, vrange[0], vrange[1], evh, Vh[0]["vertices"] if Vh else 0,
                Vh[-1]["vertices"] if Vh else 0, em,
                (" Fewer than 2 iterations (no time per iteration): %s." % "; ".join(
                    "%s %s, %d vertices: %d iterations, %s" % (x["sweep"], x["cells"], x["vertices"], x["iterations"],
                                                           x["message"][:80]) for x in short)) if short else ""), "",
            "![scaling](scaling.png)", ""]
        self.scale = dict(poses=ep, vertices=ev, poses_cpu=epc, vertices_cpu=evc, vertices_upper=evh, memory=em,
                          vrange=vrange)

    # -- 4b. threads --------------------------------------------------------
    def threads(self):
        """Time per iteration with --threads 1 against 2 (poses solved in parallel). Meaningful only on an
        otherwise idle machine; the other parts run one thread each."""
        nx, ny, k = self.L["sheet"] or (4, 5, 11)
        n = self.L["threads_poses"]
        p = self.sheet("threads", (nx, ny), k, poses=n)
        load = " ".join(open("/proc/loadavg").read().split()[:3])
        rows = []
        for th in (1, 2):
            self.log("threads: %d" % th)
            r = S.optimize(self.bin, p, self.path("threads_%d.h5" % th),
                           ["--method", "reduced", "--schedule", "joint", "--threads", str(th)] +
                           self.limits(self.L["scale_iter"], self.L["scale_time"]))
            rows.append(self.scaling_row("threads", r, n, th, (nx, ny)))
        write_csv(os.path.join(self.out, "threads.csv"), rows)
        sp = rows[0]["per_iteration_s"] / rows[1]["per_iteration_s"]
        self.md += [
            "## Threads: time per iteration with 1 and 2 threads", "",
            "`--method reduced --schedule joint --threads 1|2` on a hex sheet %dx%d cells, K = %d, %d poses "
            "(`--max-iter %d --time-limit %d`); poses are solved in parallel. Load average at the start of this "
            "part: %s (a second thread can only help if a core is free)." % (
                nx, ny, k, n, self.L["scale_iter"], self.L["scale_time"], load), "",
            table(["threads", "poses", "vertices", "iterations", "s/iteration", "process wall (s)",
                   "process CPU (s)", "CPU/wall"],
                  [[x["threads"], x["poses"], x["vertices"], x["iterations"], fmt(x["per_iteration_s"]),
                    fmt(x["process_wall_s"]), fmt(x["process_cpu_s"]), fmt(x["cpu_over_wall"])] for x in rows]), "",
            "Two threads against one: %.2fx faster per iteration." % sp, ""]
        self.thr = dict(speedup=sp)

    # -- 5. Table 2 ---------------------------------------------------------
    def table2(self):
        rows = []
        cases = [("Sheet (examples/sheet.json)", None, None, None),
                 ("Hat-sized hex sheet", (7, 8), 11, "Hat"),
                 ("Dinosaur-sized hex sheet", (10, 10), 11, "Dinosaur"),
                 ("Smiley-sized hex sheet", (15, 15), 5, None),
                 ("Sphere-sized (N) hex sheet", (9, 9), 11, "Sphere")]
        for name, cells, k, paper in cases:
            self.log("table 2: %s" % name)
            if cells is None:
                s = json.load(open(os.path.join(ROOT, "examples", "sheet.json")))
            else:
                s = S.hex_sheet(self.bin, self.path("t2.base.json"), cells, k, pulls=[(0.3, 0.0, 0.0)])
            s = dict(s)
            s["poses"] = s["poses"][:1]
            s.pop("design", None)
            sp = self.path("t2.json")
            json.dump(s, open(sp, "w"))
            nv, ne = len(s["vertices"]), sum(len(r["vertices"]) - 1 for r in s["rods"])
            _, _, _ = S.run([self.bin, "simulate", sp, "-o", sp + ".n.h5", "-q"])
            with h5py.File(sp + ".n.h5") as f:
                pn = list(f["poses"])[0]
                newton_s = float(f["poses"][pn].attrs["time_s"])
                dofs = int(f["model"].attrs["dofs_per_pose"])
            rc, _, _ = S.run([self.bin, "simulate", sp, "-o", sp + ".r.h5", "-q", "--static-solver", "relaxation",
                              "--time-limit", str(self.L["t2_relax_time"])], ok=(0, 1))
            with h5py.File(sp + ".r.h5") as f:
                pr = f["poses"][list(f["poses"])[0]]
                relax_s = float(pr.attrs["time_s"])
                relax_ok = str(pr.attrs.get("status", "")) == "converged"
                relax_it = int(pr.attrs["iterations"])
                relax_res = float(pr.attrs["residual_norm"])
            dur = self.L["t2_duration"]
            rc, wall, err = S.run([self.bin, "simulate", sp, "-o", sp + ".d.h5", "--dynamic", "--duration", str(dur)],
                                  ok=(0, 1))
            steps, rejected = S.steps_of_dynamic_run(err)[0]
            with h5py.File(sp + ".d.h5") as f:
                pd = f["poses"][list(f["poses"])[0]]
                dyn_s = float(pd.attrs["time_s"])
                dyn_newton = int(pd.attrs["iterations"])
            row = dict(scene=name, vertices=nv, edges=ne, unknowns=dofs, paper_convention_N=3 * nv + ne,
                       dt_s=dur / steps if steps else float("nan"), steps=steps, rejected=rejected,
                       newton_per_step=dyn_newton / max(steps + rejected, 1),
                       step_ms=1e3 * dyn_s / max(steps + rejected, 1), newton_s=newton_s,
                       relaxation_s=relax_s, relaxation_converged=relax_ok, relaxation_iterations=relax_it, relaxation_residual_N=relax_res,
                       paper=paper or "")
            if paper:
                pN, pdt, pt, pT = PAPER_T2[paper]
                row.update(paper_N=pN, paper_dt_s=pdt, paper_step_ms=pt, paper_static_s=pT)
            else:
                row.update(paper_N=None, paper_dt_s=None, paper_step_ms=None, paper_static_s=None)
            rows.append(row)
        write_csv(os.path.join(self.out, "table2.csv"), rows)
        self.md += [
            "## Table 2: dynamic steps and static solves", "",
            "One pose per scene: left side held, gravity, 0.3 N pull on the right side (the Sheet: its first "
            "pose, 0.5 N). The experiments' own scenes were not available to this study (they are built on "
            "another branch); the hex sheets match the paper's Table 1 vertex counts (Hat 1727, Dinosaur 3219, "
            "Smiley 2663) or, for the Sphere (not in Table 1), its N. Our N: unknowns per pose (free vertex "
            "positions and one twist per edge; held vertices are not unknowns); 3V+E: the paper's convention "
            "(all nodes and edges). Dynamic: `simulate --dynamic --duration %g` (backward Euler, adaptive "
            "steps, `--max-step` 0.01 s); dt = duration / accepted steps; t = wall time per step attempt "
            "(accepted and rejected). Static: Newton (`simulate`) and dynamic relaxation "
            "(`--static-solver relaxation --time-limit %d`), from rest. Paper: Intel i7 4470K." % (
                self.L["t2_duration"], self.L["t2_relax_time"]), "",
            table(["scene", "V", "N (ours)", "3V+E", "dt (s)", "t (ms)", "Newton its/step", "T Newton (s)",
                   "T relaxation (s)", "paper", "paper N", "paper dt (s)", "paper t (ms)", "paper T (s)"],
                  [[x["scene"], x["vertices"], x["unknowns"], x["paper_convention_N"], fmt(x["dt_s"]),
                    fmt(x["step_ms"]), fmt(x["newton_per_step"], 2), fmt(x["newton_s"]),
                    (fmt(x["relaxation_s"]) if x["relaxation_converged"] else
                     "> %s (stopped: %d its, residual %s N)" % (fmt(x["relaxation_s"]), x["relaxation_iterations"],
                                                                fmt(x["relaxation_residual_N"], 2))),
                    x["paper"] or "—", fmt(x["paper_N"]), fmt(x["paper_dt_s"]), fmt(x["paper_step_ms"]),
                    fmt(x["paper_static_s"])] for x in rows]), ""]
        self.t2 = rows

    # -- report -------------------------------------------------------------
    def header(self, load0, load1, elapsed):
        commit, dirty = self.commit
        cpu = cpu_model()
        mem = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
        return [
            "# Design study: sweeps (issue #10, items 2 and 3)", "",
            "Regenerate: `/usr/bin/python3 benchmarks/study/sweeps.py --rodmesh build/apps/rodmesh --out OUTDIR%s%s`"
            % (" --quick" if self.quick else "", (" --only " + " ".join(self.only)) if self.only else ""), "",
            "Parts run: %s." % ", ".join(self.parts), "",
            "Mode: %s. Started %s UTC, %.0f s in all. Commit %s%s. Machine: %s, %d logical CPUs, %.0f GiB, %s. "
            "**The machine was shared** with up to four other jobs (builds, tests): load average %s before and "
            "%s after; every time below is wall clock, from one run each (no repeats), and is noisy at the "
            "level of tens of percent." % (
                "quick (small sheets, short runs)" if self.quick else "full", self.started.strftime("%Y-%m-%d %H:%M"), elapsed, commit, " (with uncommitted changes)" if dirty else "", cpu,
                os.cpu_count(), mem, platform.platform(), load0, load1), ""]

    def weaknesses(self):
        """Weak points this run's numbers show, stated rather than tuned away."""
        w = []
        for m in ("reduced", "sand"):
            rr = [x for x in getattr(self, "tol_rows", []) if x["method"] == m]
            stopped = [x for x in rr if "time limit" in x["message"]]
            if stopped:
                w.append("%s: at --tol %s the run was stopped by the time limit, not by the tolerance, so those "
                         "rows measure the time budget" % (m, ", ".join("%g" % x["tol"] for x in stopped)))
            rms = [x["rms_mm"] for x in rr]
            if len(rms) > 2 and any(b > a * 1.05 for a, b in zip(rms, rms[1:])):
                w.append("%s: the final RMS does not fall monotonically as --tol tightens" % m)
        d = getattr(self, "disc_rows", [])
        if d and d[0]["rms_fine_mm"] > 2 * d[0]["rms_own_mm"]:
            w.append("a design optimized at K = %d fits its own discretization (%s mm) far better than the "
                     "object it stands for (%s mm at the fine K): coarse rods over-fit" % (
                         d[0]["k"], fmt(d[0]["rms_own_mm"], 3), fmt(d[0]["rms_fine_mm"], 3)))
        th = getattr(self, "thr", None)
        if th and th["speedup"] < 1.3:
            w.append("a second thread gained %.2fx per iteration (poses are solved in parallel; check the load "
                     "average of the threads section)" % th["speedup"])
        t2 = getattr(self, "t2", [])
        slow = [x for x in t2 if x["paper_step_ms"] and x["step_ms"] > x["paper_step_ms"]]
        if slow:
            w.append("a dynamic step is slower than the paper's on %s (%s ms against %s ms; backward Euler with "
                     "Newton, about %s Newton iterations per step)" % (
                         ", ".join(x["paper"] for x in slow), ", ".join(fmt(x["step_ms"]) for x in slow),
                         ", ".join(fmt(x["paper_step_ms"]) for x in slow),
                         fmt(float(np.mean([x["newton_per_step"] for x in slow])), 2)))
        if t2 and not all(x["dt_s"] >= x["paper_dt_s"] for x in t2 if x["paper_dt_s"]):
            w.append("our adaptive time steps are shorter than the paper's (dt column)")
        unconv = [x for x in t2 if not x["relaxation_converged"]]
        if unconv:
            w.append("dynamic relaxation did not reach the force tolerance within its %d s limit on %d of %d "
                     "scenes (Newton needs %s-%s s)" % (self.L["t2_relax_time"], len(unconv), len(t2),
                                                       fmt(min(x["newton_s"] for x in t2)),
                                                       fmt(max(x["newton_s"] for x in t2))))
        fr = {(x["scene"], x["mode"]): x for x in getattr(self, "fd_rows", [])}
        if ("main", "fd") in fr and fr[("main", "fd")]["rms_mm"] > 2 * fr[("main", "exact")]["rms_mm"]:
            w.append("within the same time limit the paper's finite differences end at %s mm against %s mm with "
                     "exact derivatives" % (fmt(fr[("main", "fd")]["rms_mm"], 3),
                                            fmt(fr[("main", "exact")]["rms_mm"], 3)))
        return ["- **Weak points this run shows**: " + "; ".join(w) + "."] if w else []

    def summary(self):
        out = ["## Answers", ""]
        h = getattr(self, "halv", [])
        if h:
            costs = [(x["halvings"], x["exact_cost_s"]) for x in h if x["exact_cost_s"] is not None]
            out.append("- **Cost of halving the RMS** (exact derivatives, main scene): " + ", ".join(
                "halving %d: %s s" % (i, fmt(c)) for i, c in costs) + "; the RMS halved %d times in the run." % (
                len(h) - 1))
            fc = [(x["halvings"], x["fd_cost_s"]) for x in h if x["fd_cost_s"] is not None]
            if fc:
                out.append("- Same with the paper's finite differences: " + ", ".join(
                    "halving %d: %s s" % (i, fmt(c)) for i, c in fc) + ".")
        if hasattr(self, "fd_rows"):
            by = {(x["scene"], x["mode"]): x for x in self.fd_rows}
            parts = []
            for key, label in (("per_it_radii_l2_s", "radii at level 2"), ("per_it_radii_l0_s", "radii at level 0")):
                e, f = by.get(("main", "exact"), {}).get(key), by.get(("main", "fd"), {}).get(key)
                if e and f and math.isfinite(e) and math.isfinite(f):
                    parts.append("%s: %s s against %s s per iteration (%.0fx)" % (label, fmt(f), fmt(e), f / e))
            e, f, g = (by.get(("tiny", m), {}).get("per_iteration_s") for m in ("exact", "fd", "fd-resolve"))
            if e and f and g:
                parts.append("tiny sheet, all variables: exact %s s, fd %s s, fd-resolve %s s per iteration" % (
                    fmt(e), fmt(f), fmt(g)))
            out.append("- **The paper's finite differences against exact derivatives** (main scene): " +
                       "; ".join(parts) + ". The gradients agree to ~1e-10 relative (tests/solver/fd_design_derivatives_test.cc); "
                       "how closely the two runs' paths agree is measured in the section below.")
        if hasattr(self, "tol_rows"):
            for m in ("reduced", "sand"):
                rr = [x for x in self.tol_rows if x["method"] == m]
                if rr:
                    out.append("- **Tolerance, %s**: " % m + "; ".join(
                        "%g: %s mm in %s s (%s)" % (x["tol"], fmt(x["rms_mm"], 3), fmt(x["time_s"]), x["status"])
                        for x in rr) + ".")
        if hasattr(self, "disc_rows"):
            out.append("- **Discretization** (design optimized at K, re-simulated at the fine K): " + "; ".join(
                "K = %d: %s mm (%s mm at K), %s s" % (x["k"], fmt(x["rms_fine_mm"], 3), fmt(x["rms_own_mm"], 3),
                                                       fmt(x["time_s"])) for x in self.disc_rows) + ".")
        if hasattr(self, "t2"):
            rr = [x for x in self.t2 if x["paper_static_s"]]
            if rr:
                out.append("- **Table 2 against the paper**: static Newton solve %s; dynamic step %s of the "
                           "paper's t (paper on an i7 4470K, ours on a loaded shared machine)." % (
                               ", ".join("%s %.0fx faster than the paper's T" % (x["paper"], x["paper_static_s"] /
                                                                                 x["newton_s"]) for x in rr),
                               ", ".join("%s %.2fx" % (x["paper"], x["step_ms"] / x["paper_step_ms"]) for x in rr)))
        out += self.weaknesses()
        if hasattr(self, "scale"):
            s = self.scale
            out.append("- **Growth of cost**: time per iteration ~ poses^%.2f and ~ vertices^%.2f (fitted, wall "
                       "clock; CPU estimate ^%.2f and ^%.2f), vertices from %d to %d." % (
                           s["poses"], s["vertices"], s["poses_cpu"], s["vertices_cpu"], s["vrange"][0],
                           s["vrange"][1]))
        if hasattr(self, "thr"):
            out.append("- **Threads**: 2 threads against 1: %.2fx faster per iteration." % self.thr["speedup"])
        return out + [""]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rodmesh", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--only", nargs="*", default=None,
                    help="run only these parts: " + " ".join(PARTS))
    args = ap.parse_args()
    st = Study(args)
    try:
        return run_parts(st, args)
    finally:
        subprocess.run(["rm", "-rf", st.tmp])


def run_parts(st, args):
    load0 = " ".join(open("/proc/loadavg").read().split()[:3])
    parts = [(name, getattr(st, PARTS[name])) for name in PARTS]
    unknown = set(args.only or []) - set(PARTS)
    if unknown:
        raise SystemExit("sweeps.py: unknown part(s) %s (parts: %s)" % (", ".join(sorted(unknown)), " ".join(PARTS)))
    failures = []
    for name, fn in parts:
        if args.only and name not in args.only:
            continue
        st.parts.append(name)
        try:
            fn()
        except Exception as e:  # one part's failure is reported, the others still run
            failures.append("%s: %s" % (name, e))
            st.log("FAILED %s: %s" % (name, e))
            st.md += ["## %s: failed" % name, "", "```", str(e)[-1500:], "```", ""]
    load1 = " ".join(open("/proc/loadavg").read().split()[:3])
    md = st.header(load0, load1, time.perf_counter() - st.t0) + st.summary() + st.md
    open(os.path.join(st.out, "sweeps.md"), "w").write("\n".join(md) + "\n")
    st.log("wrote %s" % os.path.join(st.out, "sweeps.md"))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
