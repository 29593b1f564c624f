#!/usr/bin/python3
"""Second acceptance sweep for rodmesh: runs every case of make.py with default
flags, judges exit status, accuracy against closed forms and time, writes
results.json.

    /usr/bin/python3 make.py [--rodmesh BIN] [--out CASES]
    /usr/bin/python3 run.py [--rodmesh BIN] [--cases CASES] [--out OUT] [--only SUBSTR,...]

One rodmesh process at a time; archives, logs and results.json go to OUT.
"""
import argparse
import copy
import json
import math
import os
import shutil
import subprocess
import sys
import time

import h5py
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
RODMESH = os.path.join(os.path.dirname(os.path.dirname(HERE)), "build", "apps", "rodmesh")
CASES = "/tmp/rodmesh_sweep2/cases"
OUTDIR = "/tmp/rodmesh_sweep2/out"


def run(cmd, timeout=600):
    t0 = time.time()
    try:
        r = subprocess.run([str(c) for c in cmd], capture_output=True, timeout=timeout)
        rc, out, err = r.returncode, r.stdout.decode(errors="replace"), r.stderr.decode(errors="replace")
        if b"\xef\xbf\xbd" not in r.stderr and out + err != (r.stdout + r.stderr).decode(errors="ignore"):
            err += "\n[run.py: stderr/stdout not valid UTF-8]"
    except subprocess.TimeoutExpired as e:
        rc, out, err = "timeout", (e.stdout or b"").decode(errors="replace") if isinstance(e.stdout, bytes) else (e.stdout or ""), \
            (e.stderr or b"").decode(errors="replace") if isinstance(e.stderr, bytes) else (e.stderr or "")
    return rc, time.time() - t0, out, err


def s(x):
    return x.decode() if isinstance(x, bytes) else (x if isinstance(x, str) else (x.item() if hasattr(x, "item") else x))


def pose_info(g):
    info = {k: s(g.attrs[k]) for k in g.attrs}
    for k, v in list(info.items()):
        if isinstance(v, (np.generic,)):
            info[k] = v.item()
    if "critical_points" in g:
        info["critical_points"] = g["critical_points"][()].tolist()
    return info


def read_archive(path):
    a = {"root": {}, "poses": {}}
    with h5py.File(path, "r") as f:
        for k in f.attrs:
            v = f.attrs[k]
            a["root"][k] = s(v) if not isinstance(v, np.ndarray) else v.tolist()
        a["model"] = {k: s(f["model"].attrs[k]) for k in f["model"].attrs}
        a["rest"] = f["rest/positions"][()]
        a["radii"] = f["design/radii"][()]
        for name in f["poses"]:
            g = f["poses"][name]
            a["poses"][name] = {"positions": g["positions"][()], "attrs": pose_info(g),
                                "twist": g["twist"][()] if "twist" in g else None,
                                "target": g["target"][()] if "target" in g else None}
        if "frames" in f:
            a["frames"] = {n: f["frames"][n]["time"][()] for n in f["frames"]}
    return a


def jsonable(o):
    if isinstance(o, dict):
        return {k: jsonable(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [jsonable(v) for v in o]
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, float) and not math.isfinite(o):
        return str(o)
    return o


def summarize_poses(a):
    out = {}
    for n, p in a["poses"].items():
        at = p["attrs"]
        out[n] = {k: at.get(k) for k in ("status", "iterations", "time_s", "residual_norm", "stable",
                                          "smallest_eigenvalue", "unloaded_smallest_eigenvalue",
                                          "out_of_plane_stable", "critical_points", "rms_error") if k in at}
        out[n]["max_displacement"] = float(np.max(np.linalg.norm(p["positions"] - a["rest"], axis=1)))
    return out


# ------------------------------------------------------------------ kinds
def do_simulate(case, extra=()):
    out = os.path.join(OUTDIR, case["name"] + ".h5")
    if os.path.exists(out):
        os.remove(out)
    cmd = [RODMESH, "simulate", case["scene"], "-o", out] + list(case["args"]) + list(extra)
    rc, dt, so, se = run(cmd, timeout=600)
    res = {"cmd": " ".join(map(str, cmd)), "exit": rc, "wall_s": round(dt, 3),
           "stderr_tail": se[-1500:]}
    a = None
    if os.path.exists(out):
        try:
            a = read_archive(out)
            res["status"] = a["root"].get("status")
            res["message"] = a["root"].get("message")
            res["effects_note"] = a["root"].get("effects_note")
            res["model"] = {k: a["model"].get(k) for k in ("effects", "planar", "dofs_per_pose")}
            res["poses"] = summarize_poses(a)
            # contract: "converged always means a stable equilibrium" (docs/formats.md)
            viol = []
            for pn, pv in a["poses"].items():
                at = pv["attrs"]
                if at.get("status") == "converged":
                    if at.get("stable") == 0:
                        viol.append("pose %s: status converged but stable = 0" % pn)
                    if not (at.get("residual_norm", 0) < 1e-6):
                        viol.append("pose %s: status converged with residual_norm %g N" % (pn, at.get("residual_norm")))
            if viol:
                res["contract_violations"] = viol
        except Exception as e:  # noqa
            res["archive_error"] = repr(e)
    return res, a


def judge_closed(case, res, a):
    ref = case["ref"]
    errs = []
    if a is None:
        res["verdict"] = "no archive"
        return
    for c in ref.get("checks", []):
        p = a["poses"][c["pose"]]
        x = p["positions"][c["vertex"]]
        exp = np.asarray(c["expected"])
        rest = a["rest"][c["vertex"]]
        disp = np.linalg.norm(exp - rest)
        scale = ref.get("disp_scale", disp)
        if scale < 1e-12:  # reference does not move: relative to the rod length scale
            scale = float(np.linalg.norm(np.ptp(a["rest"], axis=0)))
        e = float(np.linalg.norm(x - exp) / scale)
        errs.append({"pose": c["pose"], "vertex": c["vertex"], "rel_error": e, "abs_error_m": float(np.linalg.norm(x - exp)),
                     "got": x.tolist(), "expected": exp.tolist(), "ref_displacement_m": float(disp)})
    for c in ref.get("twist_checks", []):
        tw = a["poses"][c["pose"]]["twist"]
        if tw is None:
            errs.append({"twist": "missing"})
            continue
        got = float(tw[c["edge"]])
        errs.append({"pose": c["pose"], "edge": c["edge"], "twist_got": got, "twist_expected": c["expected"],
                     "rel_error": abs(got - c["expected"]) / abs(c["expected"])})
    res["errors"] = errs
    res["max_rel_error"] = max([e.get("rel_error", float("nan")) for e in errs] or [float("nan")])
    res["edges"] = ref.get("edges")
    res["formula"] = ref.get("formula")


def judge_planar(case, res, a):
    if a is None:
        return
    p = a["poses"]["load"]
    x = p["positions"]
    d = x - a["rest"]
    res["max_abs_z_m"] = float(np.max(np.abs(x[:, 2] - a["rest"][:, 2])))
    res["max_inplane_disp_m"] = float(np.max(np.linalg.norm(d[:, :2], axis=1)))
    res["ref"] = case["ref"]


def judge_dynamic(case, res, a, static_archives):
    if a is None:
        return
    st = static_archives.get(case["ref"]["static_case"])
    x = a["poses"]["load"]["positions"]
    res["max_abs_z_m"] = float(np.max(np.abs(x[:, 2] - a["rest"][:, 2])))
    res["frames"] = len(a.get("frames", {}).get("load", []))
    if st is not None:
        xs = st["poses"]["load"]["positions"]
        res["max_dist_to_static_m"] = float(np.max(np.linalg.norm(x - xs, axis=1)))
        res["static_max_disp_m"] = float(np.max(np.linalg.norm(xs - st["rest"], axis=1)))
        res["dynamic_max_disp_m"] = float(np.max(np.linalg.norm(x - a["rest"], axis=1)))


def do_bad(case, good_archive):
    out = os.path.join(OUTDIR, case["name"] + ".h5")
    scene = case["scene"]
    if scene == "__ARCHIVE__":
        scene = good_archive
    pre = case["ref"].get("preexisting_output")
    if os.path.exists(out):
        os.remove(out)
    if pre:
        with open(out, "wb") as f:
            f.write(b"previous archive bytes")
    cmd_kind = "optimize" if case["kind"] == "bad_optimize" else "simulate"
    cmd = [RODMESH, cmd_kind, scene, "-o", out]
    rc, dt, so, se = run(cmd, timeout=120)
    lines = [l for l in se.strip().splitlines() if l.strip()]
    err_lines = [l for l in lines if "error" in l.lower()]
    res = {"cmd": " ".join(cmd), "exit": rc, "wall_s": round(dt, 3), "expect_exit": case["ref"].get("expect_exit"),
           "stderr_lines": len(lines), "stderr_head": se.strip()[:600], "note": case.get("note", "")}
    if pre:
        res["output_unchanged"] = os.path.exists(out) and open(out, "rb").read() == b"previous archive bytes"
    else:
        res["output_exists"] = os.path.exists(out)
    tmp = [f for f in os.listdir(OUTDIR) if f.startswith(case["name"] + ".h5.tmp")]
    res["tmp_left"] = tmp
    fname = os.path.basename(scene)
    res["names_file"] = fname in se
    exp = case["ref"].get("expect_exit")
    ok = True
    if exp is not None and rc != exp:
        ok = False
    if rc == 2:
        if (pre and not res["output_unchanged"]) or (not pre and res["output_exists"]):
            ok = False
        if not res["names_file"]:
            ok = False
    res["ok"] = ok
    return res


def bad_archives(good):
    """Malformed archives for inspect / export / simulate."""
    d = os.path.join(OUTDIR, "bad_archives")
    os.makedirs(d, exist_ok=True)
    data = open(good, "rb").read()
    made = {}

    def raw(name, b):
        p = os.path.join(d, name + ".h5")
        open(p, "wb").write(b)
        made[name] = p

    raw("truncated_half", data[: len(data) // 2])
    raw("truncated_4k", data[:4096])
    raw("empty", b"")
    raw("text", b"this is not hdf5\n")
    rng = np.random.default_rng(1)
    flipped = bytearray(data)
    for i in rng.integers(512, len(data), 40):
        flipped[i] ^= 0xFF
    raw("bitflips", bytes(flipped))

    def mod(name, fn):
        p = os.path.join(d, name + ".h5")
        shutil.copy(good, p)
        with h5py.File(p, "r+") as f:
            fn(f)
        made[name] = p

    def setpos(f, val):
        x = f["poses/p/positions"][()]
        x[2, 1] = val
        f["poses/p/positions"][...] = x

    mod("pos_nan", lambda f: setpos(f, np.nan))
    mod("pos_inf", lambda f: setpos(f, np.inf))

    def radii_neg(f):
        r = f["design/radii"][()]
        r[1, 0] = -1e-3
        f["design/radii"][...] = r
    mod("radii_negative", radii_neg)
    mod("no_poses", lambda f: f.__delitem__("poses"))
    mod("no_scene", lambda f: f.__delitem__("scene"))

    def scene_garbage(f):
        del f["scene"]
        f.create_dataset("scene", data="{not json", dtype=h5py.string_dtype())
    mod("scene_garbage", scene_garbage)

    def pos_shape(f):
        del f["poses/p/positions"]
        f["poses/p/positions"] = np.zeros((3, 3))
    mod("pos_wrong_shape", pos_shape)
    mod("status_bogus", lambda f: f.attrs.__setitem__("status", "great"))
    mod("nvertices_huge", lambda f: f["model"].attrs.__setitem__("n_vertices", 2 ** 40))

    def softlink(f):
        del f["poses/p/positions"]
        f["poses/p/positions"] = h5py.SoftLink("/rest/positions")
    mod("softlink_positions", softlink)
    return made


def do_archive_checks(good):
    made = bad_archives(good)
    rows = []
    for name, p in made.items():
        for cmd_kind in ("inspect", "export"):
            outp = os.path.join(OUTDIR, "bad_archives", name + "_export.vtp")
            if os.path.exists(outp):
                os.remove(outp)
            cmd = [RODMESH, "inspect", p] if cmd_kind == "inspect" else [RODMESH, "export", p, "-o", outp]
            rc, dt, so, se = run(cmd, timeout=60)
            lines = [l for l in se.strip().splitlines() if l.strip()]
            r = {"archive": name, "cmd": " ".join(cmd), "exit": rc, "wall_s": round(dt, 3),
                 "stderr_lines": len(lines), "stderr_head": se.strip()[:400],
                 "stdout_head": so.strip()[:200]}
            if cmd_kind == "export":
                r["output_exists"] = os.path.exists(outp)
            r["ok"] = rc == 2 and len(lines) == 1 and not r.get("output_exists", False)
            rows.append(r)
    return rows


def do_optimize(case):
    out = os.path.join(OUTDIR, case["name"] + ".h5")
    if os.path.exists(out):
        os.remove(out)
    cmd = [RODMESH, "optimize", case["scene"], "-o", out]
    rc, dt, so, se = run(cmd, timeout=900)
    res = {"cmd": " ".join(cmd), "exit": rc, "wall_s": round(dt, 3), "stderr_tail": se[-2500:]}
    if not os.path.exists(out):
        return res
    a = read_archive(out)
    res["status"] = a["root"].get("status")
    res["message"] = a["root"].get("message")
    res["archived_design"] = a["root"].get("archived_design")
    res["iterations"] = a["root"].get("iterations")
    res["poses"] = summarize_poses(a)
    # RMS recomputed from the archive
    tot, cnt = 0.0, 0
    per = {}
    for n, p in a["poses"].items():
        d2 = np.sum((p["positions"] - p["target"]) ** 2, axis=1)
        per[n] = {"rms_computed_m": float(math.sqrt(d2.mean())), "rms_archived_m": p["attrs"].get("rms_error"),
                  "equilibrium_gap": p["attrs"].get("equilibrium_gap"),
                  "imperfection_sensitive": p["attrs"].get("imperfection_sensitive")}
        tot += d2.sum()
        cnt += len(d2)
    res["rms_all_computed_m"] = math.sqrt(tot / cnt)
    res["per_pose_rms"] = per
    with h5py.File(out, "r") as f:
        if "history" in f:
            h = f["history"]
            res["history_last_rms_m"] = float(h["rms_error"][-1])
            res["history_first_rms_m"] = float(h["rms_error"][0])
            if "confirmed_rms" in h:
                res["history_last_confirmed_rms_m"] = float(h["confirmed_rms"][-1])
        scene = json.loads(s(f["scene"][()]))
    rc2, dt2, so2, se2 = run([RODMESH, "inspect", out], timeout=60)
    res["inspect_rms_lines"] = [l for l in (so2 + se2).splitlines() if "RMS" in l or "rms" in l][:8]
    # re-simulate the archived design
    scene["vertices"] = a["rest"].tolist()
    scene.pop("radius", None)
    scene["radii"] = a["radii"].tolist()
    rpath = os.path.join(OUTDIR, case["name"] + "_resim.json")
    json.dump(scene, open(rpath, "w"))
    rout = os.path.join(OUTDIR, case["name"] + "_resim.h5")
    if os.path.exists(rout):
        os.remove(rout)
    rc3, dt3, so3, se3 = run([RODMESH, "simulate", rpath, "-o", rout], timeout=300)
    res["resim"] = {"cmd": "%s simulate %s -o %s" % (RODMESH, rpath, rout), "exit": rc3, "wall_s": round(dt3, 3)}
    if os.path.exists(rout):
        b = read_archive(rout)
        res["resim"]["max_position_diff_m"] = max(float(np.max(np.linalg.norm(b["poses"][n]["positions"] - a["poses"][n]["positions"], axis=1)))
                                                  for n in a["poses"])
        res["resim"]["rms_archived_vs_resim"] = {n: [a["poses"][n]["attrs"].get("rms_error"), b["poses"][n]["attrs"].get("rms_error")]
                                                 for n in a["poses"]}
        res["resim"]["status"] = b["root"].get("status")
    return res


def main():
    global RODMESH, CASES, OUTDIR
    ap = argparse.ArgumentParser()
    ap.add_argument("--rodmesh", default=RODMESH)
    ap.add_argument("--cases", default=CASES, help="make.py's --out")
    ap.add_argument("--out", default=OUTDIR, help="archives, logs and results.json")
    ap.add_argument("--only", default="")
    ap.add_argument("--skip", default="")
    a = ap.parse_args()
    RODMESH, CASES, OUTDIR = a.rodmesh, a.cases, a.out
    os.makedirs(OUTDIR, exist_ok=True)
    cases = json.load(open(os.path.join(CASES, "cases.json")))
    only = [x for x in a.only.split(",") if x]
    skip = [x for x in a.skip.split(",") if x]
    if only:
        cases = [c for c in cases if any(o in c["name"] for o in only)]
    if skip:
        cases = [c for c in cases if not any(o in c["name"] for o in skip)]
    rpath = os.path.join(OUTDIR, "results.json")
    results = json.load(open(rpath)) if os.path.exists(rpath) and (only or skip) else {}
    results.setdefault("cases", {})
    st = os.stat(RODMESH)
    results["rodmesh"] = {"path": RODMESH, "mtime": time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime(st.st_mtime)),
                          "size": st.st_size}
    static_archives = {}
    good_archive = os.path.join(OUTDIR, "bad_control_good.h5")
    for c in cases:
        t0 = time.time()
        k = c["kind"]
        if k in ("closed", "edge", "planar"):
            res, arc = do_simulate(c)
            if k == "closed":
                judge_closed(c, res, arc)
            elif k == "planar":
                judge_planar(c, res, arc)
                static_archives[c["name"]] = arc
            else:
                res["note"] = c.get("note")
                res["ref"] = c.get("ref")
        elif k == "planar_dynamic":
            st = c["ref"]["static_case"]
            if st not in static_archives and os.path.exists(os.path.join(OUTDIR, st + ".h5")):
                static_archives[st] = read_archive(os.path.join(OUTDIR, st + ".h5"))
            res, arc = do_simulate(c)
            judge_dynamic(c, res, arc, static_archives)
        elif k in ("bad", "bad_optimize"):
            res = do_bad(c, good_archive)
        elif k == "optimize":
            res = do_optimize(c)
        else:
            continue
        res["kind"] = k
        res["group"] = c["group"]
        res["scene"] = c["scene"]
        results["cases"][c["name"]] = jsonable(res)
        print("%-44s exit %-7s %7.2fs %s%s" % (c["name"], res.get("exit"), time.time() - t0, "CONTRACT " if res.get("contract_violations") else "",
                                            ("err %.3g" % res["max_rel_error"]) if "max_rel_error" in res else
                                            ("ok" if res.get("ok") else ("" if "ok" not in res else "NOT OK"))), flush=True)
        json.dump(results, open(rpath, "w"), indent=1)
    if (not only or "archive" in only) and os.path.exists(good_archive) and "archives" not in skip:
        results["bad_archives"] = jsonable(do_archive_checks(good_archive))
        for r in results["bad_archives"]:
            print("archive %-20s %-8s exit %s %s" % (r["archive"], r["cmd"].split()[1], r["exit"], "ok" if r["ok"] else "NOT OK"))
    json.dump(results, open(rpath, "w"), indent=1)


if __name__ == "__main__":
    main()
