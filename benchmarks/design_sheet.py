#!/usr/bin/python3
"""The paper's four-pose Sheet experiment as one scene (kept for the commands
quoted in benchmarks/results/design.md and sand.md). The scene is built by
benchmarks/study/make_scenes.py (`--only sheet`), which holds its description;
its pull poses are stronger (3 N) than in the version those results used
(0.3 N, see git history).

usage: design_sheet.py RODMESH OUT.json
"""
import json
import os
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "study"))
import make_scenes  # noqa: E402

rodmesh, out = sys.argv[1], sys.argv[2]
with tempfile.TemporaryDirectory() as tmp:
    scene, _ = make_scenes.make_sheet(rodmesh, tmp)
json.dump(scene, open(out, "w"))
print("wrote", out, len(scene["vertices"]), "vertices,", len(scene["poses"]), "poses")
