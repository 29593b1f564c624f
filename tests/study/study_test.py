#!/usr/bin/python3
"""Tests of the design study's scripts (benchmarks/study/).

    /usr/bin/python3 tests/study/study_test.py RODMESH [unittest args]

Scene generator: the Sheet, Hat (4 poses) and Dino scenes have the paper's
sizes, and every target moves the way its supports and loads say it must
(checked on the targets, against expectations from the physics of each pose,
not against numbers the generator printed). Report helpers: the equilibrium
curve, the time to a given RMS and the RMS after radii, on hand-made
histories. Sweeps: the part list (threads is a part of its own, scaling no
longer runs it) and merge_sweeps.py on hand-made sweeps.md files.
"""
import os
import sys
import tempfile
import unittest

import numpy as np

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
sys.path.insert(0, os.path.join(ROOT, "benchmarks", "study"))
import make_scenes  # noqa: E402
import merge_sweeps  # noqa: E402
import report  # noqa: E402
import sweeps  # noqa: E402

RODMESH = None


def history(time, rms_mm, viol, phase=None):
    n = len(time)
    return dict(initial=rms_mm[0] * 1e-3, history=dict(
        time=np.array(time, float), rms=1e-3 * np.array(rms_mm, float), viol=np.array(viol, float),
        phase=np.array(phase or ["initial"] + ["radii"] * (n - 1)), level=np.zeros(n, int),
        iteration=np.arange(n)))


class ReportHelpers(unittest.TestCase):
    def test_time_to_counts_only_equilibria(self):
        # The iterate at t = 2 s has RMS 3.9 mm but is 1e-3 N off equilibrium:
        # the first equilibrium at or below 4 mm is the one at t = 3 s.
        r = history([0, 1, 2, 3, 4], [8, 5, 3.9, 2.1, 0.9], [0, 0, 1e-3, 0, 0])
        self.assertEqual(report.time_to(r, 4e-3), 3.0)
        self.assertEqual(report.time_to(r, 5e-3), 1.0)
        self.assertEqual(report.time_to(r, 1e-3), 4.0)
        self.assertIsNone(report.time_to(r, 0.5e-3))

    def test_equilibrium_curve_is_best_so_far(self):
        r = history([0, 1, 2, 3], [8, 4, 6, 3], [0, 0, 0, 0])
        t, q = report.equilibrium_curve(r)
        np.testing.assert_array_equal(t, [0, 1, 2, 3])
        np.testing.assert_allclose(q, [8e-3, 4e-3, 4e-3, 3e-3])

    def test_after_radii_stops_at_first_rest_shape_phase(self):
        r = history([0, 1, 2, 3, 4, 5], [8, 5, 4, 3, 2, 1], [0, 0, 0, 1e-2, 0, 0],
                    ["initial", "radii", "radii", "radii", "rest_shape", "radii"])
        # Iterate 3 (3 mm) is off equilibrium; the last equilibrium radii
        # iterate before the rest shape starts is iterate 2 (4 mm).
        value, reached = report.after_radii(r)
        self.assertAlmostEqual(value, 4e-3)
        self.assertTrue(reached)
        value, reached = report.after_radii(history([0, 1], [8, 5], [0, 0]))
        self.assertAlmostEqual(value, 5e-3)
        self.assertFalse(reached)


def one_run(parts, tag):
    """A sweeps.md as sweeps.py writes it, for the given parts."""
    titles = {"tolerance": "Tolerance sweep", "discretization": "Discretization sweep",
              "fd": "The paper's recipe against ours: finite-difference design derivatives",
              "scaling": "Scaling: time per iteration against poses and vertices",
              "threads": "Threads: time per iteration with 1 and 2 threads",
              "table2": "Table 2: dynamic steps and static solves"}
    md = ["# Design study: sweeps (issue #10, items 2 and 3)", "", "Regenerate: `sweeps.py --only %s`" % " ".join(parts),
          "", "Parts run: %s." % ", ".join(parts), "", "Mode: full. Started %s." % tag, "", "## Answers", ""]
    md += ["- **%s** answer from %s." % (p, tag) for p in parts] + [""]
    for p in parts:
        md += ["## " + titles[p], "", "%s body from %s." % (p, tag), "", "### A subsection of %s" % p, "", "text", ""]
    return "\n".join(md)


class Sweeps(unittest.TestCase):
    def test_parts(self):
        self.assertEqual(list(sweeps.PARTS), ["tolerance", "discretization", "fd", "scaling", "threads", "table2"])
        self.assertEqual(list(sweeps.PARTS), merge_sweeps.PARTS)
        for name, method in sweeps.PARTS.items():
            self.assertTrue(callable(getattr(sweeps.Study, method)), name)
        # scaling no longer runs the 1-against-2-threads comparison; threads does.
        import inspect
        self.assertNotIn('"--threads", str(', inspect.getsource(sweeps.Study.scaling))
        self.assertIn('"--threads", str(th)', inspect.getsource(sweeps.Study.threads))

    def test_merge(self):
        old = one_run(["fd", "table2"], "run A")
        new = one_run(["tolerance", "scaling"], "run B")
        text = merge_sweeps.merge([old, new])
        heads = [ln for ln in text.split("\n") if ln.startswith("## ")]
        # Sections once each, in the parts' order; the runs' answers under one heading.
        self.assertEqual([h.split(":")[0].split(" sweep")[0] for h in heads],
                         ["## Runs and answers", "## Tolerance", "## The paper's recipe against ours", "## Scaling",
                          "## Table 2"])
        self.assertIn("### Parts fd, table2", text)
        self.assertIn("### Parts tolerance, scaling", text)
        self.assertIn("- **fd** answer from run A.", text)
        self.assertIn("### A subsection of fd", text)
        # Merging the merged file again changes nothing; a later run of a part replaces it.
        self.assertEqual(merge_sweeps.merge([text]), text)
        again = merge_sweeps.merge([text, one_run(["table2", "threads"], "run C")])
        self.assertIn("table2 body from run C.", again)
        self.assertNotIn("table2 body from run A.", again)
        self.assertIn("fd body from run A.", again)
        self.assertIn("*Re-run later: table2;", again)
        self.assertIn("## Threads", again)
        # A run all of whose parts were re-run is dropped.
        self.assertNotIn("run A", merge_sweeps.merge([old, one_run(["fd", "table2"], "run D")]))


@unittest.skipIf(RODMESH is None and len(sys.argv) < 2, "needs the rodmesh executable")
class Scenes(unittest.TestCase):
    def make(self, name, **kw):
        with tempfile.TemporaryDirectory() as tmp:
            return make_scenes.EXPERIMENTS[name](RODMESH, tmp, **kw)

    def check_common(self, scene, n_poses):
        V = np.array(scene["vertices"])
        self.assertEqual(len(scene["poses"]), n_poses)
        lo, hi = scene["design"]["radius_bounds"]
        self.assertTrue(all(lo <= r <= hi for r in scene["radius"]))
        self.assertNotIn("radii", scene)  # the design to optimize starts uniform
        for p in scene["poses"]:
            T = np.array(p["target"])
            self.assertEqual(T.shape, V.shape)
            for h in p.get("fixed", []) + p.get("clamped", []):  # held at rest
                np.testing.assert_allclose(T[h["vertex"]], V[h["vertex"]], atol=1e-12)
        return V, {p["name"]: np.array(p["target"]) for p in scene["poses"]}

    def test_sheet(self):
        scene, _ = self.make("sheet")
        self.assertEqual(make_scenes.counts(scene), dict(nodes=693, edges=710, rods=71, connections=54))
        V, T = self.check_common(scene, 4)
        left, right = V[:, 0] < V[:, 0].min() + 1e-6, V[:, 0] > V[:, 0].max() - 1e-6
        top = V[:, 1] > V[:, 1].max() - 1e-6
        # Hanging from one side under gravity, the other side falls.
        self.assertLess((T["hang_left"] - V)[right, 2].mean(), -0.02)
        self.assertLess((T["hang_right"] - V)[left, 2].mean(), -0.01)
        # Soft bending (hang_left) sags further than stiff bending (hang_right).
        self.assertGreater(-(T["hang_left"] - V)[right, 2].mean(), -(T["hang_right"] - V)[left, 2].mean())
        # Pulled in +x / +y: that side moves that way, stretching the sheet by
        # the same strain (within 10 %) in both directions.
        strain_x = (T["pull_right"] - V)[right, 0].mean() / np.ptp(V[:, 0])
        strain_y = (T["pull_up"] - V)[top, 1].mean() / np.ptp(V[:, 1])
        self.assertGreater(strain_x, 0.03)
        self.assertGreater(strain_y, 0.03)
        self.assertLess(abs(strain_x - strain_y), 0.1 * strain_x)

    def test_hat4(self):
        scene, _ = self.make("hat4")
        c = make_scenes.counts(scene)
        self.assertTrue(1500 <= c["nodes"] <= 1900 and 100 <= c["connections"] <= 130, c)
        V, T = self.check_common(scene, 4)
        rho = np.hypot(V[:, 0] / 1.15, V[:, 1])
        front = (rho > 0.09) & (V[:, 0] > 0.09)
        left = (rho > 0.09) & (V[:, 1] > 0.09)
        self.assertLess((T["front_down"] - V)[front, 2].mean(), -0.01)
        self.assertGreater((T["front_up"] - V)[front, 2].mean(), 0.005)
        self.assertGreater((T["front_twist"] - V)[front, 1].mean(), 0.005)
        self.assertLess((T["left_down"] - V)[left, 2].mean(), -0.01)
        self.assertEqual(scene["gravity"], [0, 0, -9.81])

    def test_dino(self):
        scene, records = self.make("dino")
        c = make_scenes.counts(scene)
        self.assertTrue(2900 <= c["nodes"] <= 3500 and 200 <= c["connections"] <= 240, c)
        V, T = self.check_common(scene, 5)
        head, tail = V[:, 0] > 0.07, V[:, 0] < -0.08
        self.assertLess((T["head_tip"] - V)[head, 2].mean(), -0.003)  # the heavy head tips down
        self.assertGreater((T["tail_up"] - V)[tail, 2].mean(), 0.003)
        self.assertGreater((T["tail_side"] - V)[tail, 1].mean(), 0.003)
        self.assertGreater((T["head_turn"] - V)[head, 1].mean(), 0.003)
        self.assertGreater((T["lean"] - V)[V[:, 2] > 0.03, 1].mean(), 0.003)


if __name__ == "__main__":
    if len(sys.argv) >= 2 and not sys.argv[1].startswith("-"):
        RODMESH = sys.argv.pop(1)
    unittest.main()
