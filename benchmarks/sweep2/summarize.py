#!/usr/bin/python3
"""Print the table of OUT/results.json (after run.py): summarize.py [OUT]."""
import json, math, os, sys
out = sys.argv[1] if len(sys.argv) > 1 else "/tmp/rodmesh_sweep2/out"
r = json.load(open(os.path.join(out, "results.json")))
print("rodmesh:", r.get("rodmesh"))
for n, c in r["cases"].items():
    if c["kind"] in ("bad", "bad_optimize"):
        continue
    extra = ""
    if "max_rel_error" in c:
        extra = "rel.err %.3g" % c["max_rel_error"]
    if c["kind"].startswith("planar"):
        extra = "max|z| %.3g m, in-plane %.3g m" % (c.get("max_abs_z_m", float("nan")), c.get("max_inplane_disp_m", float("nan")))
        if "max_dist_to_static_m" in c:
            extra += ", |dyn-static| %.3g m" % c["max_dist_to_static_m"]
    if c["kind"] == "optimize":
        extra = "RMS %.3g m (archived = computed), resim diff %.3g m" % (c["rms_all_computed_m"], c["resim"].get("max_position_diff_m", float("nan")))
    cps = [p.get("critical_points") for p in (c.get("poses") or {}).values() if p.get("critical_points")]
    if cps:
        extra += " cp@%s" % ",".join("%.3g" % q[0][0] for q in cps)
    if c.get("contract_violations"):
        extra += " VIOLATION: " + "; ".join(c["contract_violations"])
    print("%-42s exit %-3s %-13s %7.2fs  %s" % (n, c.get("exit"), c.get("status"), c.get("wall_s", 0), extra))
bad = [c for c in r["cases"].values() if c["kind"] in ("bad", "bad_optimize")]
print("bad inputs: %d, as expected %d; not: %s" % (len(bad), sum(c["ok"] for c in bad),
      [n for n, c in r["cases"].items() if c["kind"].startswith("bad") and not c["ok"]]))
ba = r.get("bad_archives", [])
print("bad archives: %d runs, exit 2 + one line + no output: %d" % (len(ba), sum(x["ok"] for x in ba)))
