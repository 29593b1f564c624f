#!/usr/bin/python3
"""Writes a damaged copy of a rodmesh archive, for tests/cli/bad_archive_cli_test.cc.

    corrupt_archive.py MODE IN.h5 OUT.h5

MODE names one kind of damage (see DAMAGE below). The archive IN.h5 must be a
`simulate` archive of tests/cli/cantilever.json (poses "small" with a target
and "large"); modes starting with "frames_" need a `simulate --dynamic` one.
"""
import json
import shutil
import sys

import h5py
import numpy as np


def replace(f, path, data, **kw):
    del f[path]
    f.create_dataset(path, data=data, **kw)


def put(f, path, **kw):
    """Creates dataset `path`, replacing one already there."""
    if path in f:
        del f[path]
    f.create_dataset(path, **kw)


def set_scene(f, edit):
    scene = f["scene"][()].decode()
    del f["scene"]
    f.create_dataset("scene", data=edit(scene), dtype=h5py.string_dtype("utf-8"))


def one_more_vertex(text):
    scene = json.loads(text)
    scene["vertices"].append([0.12, 0, 0])
    scene["rods"][0]["vertices"].append(len(scene["vertices"]) - 1)
    for pose in scene["poses"]:
        pose.pop("target", None)
    return json.dumps(scene)


DAMAGE = {
    # missing parts
    "no_scene": lambda f: f.__delitem__("scene"),
    "no_rest": lambda f: f.__delitem__("rest/positions"),
    "no_radii": lambda f: f.__delitem__("design/radii"),
    "no_pose_positions": lambda f: f.__delitem__("poses/small/positions"),
    "no_poses": lambda f: f.__delitem__("poses"),
    "empty_poses": lambda f: [f["poses"].__delitem__(n) for n in list(f["poses"])],
    "no_status": lambda f: f.attrs.__delitem__("status"),
    "no_n_vertices": lambda f: f["model"].attrs.__delitem__("n_vertices"),
    "no_residual": lambda f: f["poses/large"].attrs.__delitem__("residual_norm"),
    # wrong shapes
    "rest_two_columns": lambda f: replace(f, "rest/positions", f["rest/positions"][:, :2]),
    "rest_one_dimensional": lambda f: replace(f, "rest/positions", f["rest/positions"][()].ravel()),
    "pose_short": lambda f: replace(f, "poses/large/positions", f["poses/large/positions"][:-1]),
    "target_long": lambda f: replace(f, "poses/small/target", np.vstack([f["poses/small/target"][()]] * 2)),
    "radii_three_columns": lambda f: replace(f, "design/radii", np.ones((f["design/radii"].shape[0], 3)) * 1e-3),
    "twist_wrong_length": lambda f: put(f, "poses/large/twist", data=np.zeros(2)),
    "scalar_rest": lambda f: replace(f, "rest/positions", 1.0),
    "empty_rest": lambda f: replace(f, "rest/positions", np.zeros((0, 3))),
    # wrong types
    "rest_strings": lambda f: replace(f, "rest/positions", np.array([["a", "b", "c"]] * f["rest/positions"].shape[0], dtype="S1")),
    "rest_compound": lambda f: replace(f, "rest/positions", np.zeros(f["rest/positions"].shape[0], dtype=[("x", "f8"), ("y", "f8"), ("z", "f8")])),
    "scene_numbers": lambda f: replace(f, "scene", np.arange(3.0)),
    "status_number": lambda f: f.attrs.__setitem__("status", 7),
    "n_vertices_string": lambda f: f["model"].attrs.__setitem__("n_vertices", "six"),
    "n_vertices_fraction": lambda f: f["model"].attrs.__setitem__("n_vertices", 6.5),
    "residual_string": lambda f: f["poses/large"].attrs.__setitem__("residual_norm", "small"),
    "rest_is_group": lambda f: (f.__delitem__("rest/positions"), f["rest"].create_group("positions")),
    "poses_is_dataset": lambda f: (f.__delitem__("poses"), f.create_dataset("poses", data=np.zeros(3))),
    "rest_soft_link": lambda f: (f.__delitem__("rest/positions"), f["rest"].__setitem__("positions", h5py.SoftLink("/poses/large/positions"))),
    "rest_external_link": lambda f: (f.__delitem__("rest/positions"), f["rest"].__setitem__("positions", h5py.ExternalLink("/etc/passwd", "/x"))),
    # huge declared sizes (chunked, never written: nothing on disk)
    "huge_rest": lambda f: (f.__delitem__("rest/positions"), f["rest"].create_dataset("positions", shape=(2**40, 3), dtype="f8", chunks=(1024, 3))),
    "huge_twist": lambda f: (f["model"].attrs.__setitem__("n_edges", np.int64(2**31 - 1)), put(f, "poses/large/twist", shape=(2**31 - 1,), dtype="f8", chunks=(4096,))),
    "huge_string": lambda f: (f.__delitem__("scene"), f.create_dataset("scene", shape=(), dtype=h5py.string_dtype("utf-8", 2**31 - 2))),
    # bad values
    "nan_pose": lambda f: f["poses/large/positions"].__setitem__((2, 1), np.nan),
    "nan_pose_named_with_escapes": lambda f: (f["poses/large/positions"].__setitem__((2, 1), np.nan),
                                              f["poses"].move("large", "lar\nge\x1b[2J")),
    "inf_rest": lambda f: f["rest/positions"].__setitem__((0, 0), np.inf),
    "negative_radius": lambda f: f["design/radii"].__setitem__((3, 1), -1e-3),
    "nan_residual_converged": lambda f: f["poses/large"].attrs.__setitem__("residual_norm", np.nan),
    "status_unknown": lambda f: f.attrs.__setitem__("status", "maybe"),
    # not damage: a pose that failed may report a residual it could not compute
    "failed_pose_nan_residual": lambda f: (f["poses/large"].attrs.__setitem__("residual_norm", np.nan),
                                           f["poses/large"].attrs.__setitem__("status", "failed"),
                                           f.attrs.__setitem__("status", "failed")),
    # disagreement with the scene or /model
    "n_vertices_mismatch": lambda f: f["model"].attrs.__setitem__("n_vertices", np.int64(7)),
    "n_edges_mismatch": lambda f: f["model"].attrs.__setitem__("n_edges", np.int64(9)),
    "scene_not_json": lambda f: set_scene(f, lambda s: s[: len(s) // 2]),
    "scene_other_vertices": lambda f: set_scene(f, one_more_vertex),
    "scene_deep": lambda f: set_scene(f, lambda s: "[" * 100000 + "]" * 100000),
    # optimize parts
    "history_mismatch": lambda f: (f.create_group("history"), f["history"].create_dataset("iteration", data=np.arange(3)),
                                   f["history"].create_dataset("time_s", data=np.zeros(3)),
                                   f["history"].create_dataset("objective", data=np.zeros(2)),
                                   f["history"].create_dataset("rms_error", data=np.zeros(3))),
    "control_rod_out_of_range": lambda f: (f["design"].create_group("control_points"),
                                           f["design/control_points"].create_dataset("rod", data=np.array([-1, 5], dtype="i4")),
                                           f["design/control_points"].create_dataset("arc_fraction", data=np.array([0.0, 0.5]))),
    "control_arc_fraction": lambda f: (f["design"].create_group("control_points"),
                                       f["design/control_points"].create_dataset("rod", data=np.array([-1, 0], dtype="i4")),
                                       f["design/control_points"].create_dataset("arc_fraction", data=np.array([0.0, 2.0]))),
    "control_bound_counts": lambda f: (f["design"].create_group("control_points"),
                                       f["design/control_points"].create_dataset("rod", data=np.array([-1, 0], dtype="i4")),
                                       f["design/control_points"].create_dataset("arc_fraction", data=np.array([0.0, 0.5])),
                                       [f["design/control_points"].attrs.__setitem__(k, v) for k, v in
                                        (("radius_min", 1e-3), ("radius_max", 5e-3), ("radii_at_min", 3),
                                         ("radii_at_max", 2), ("elasticity_min", 0.5), ("elasticity_max", -0.5))]),
    "control_bound_elasticity": lambda f: (f["design"].create_group("control_points"),
                                           f["design/control_points"].create_dataset("rod", data=np.array([-1, 0], dtype="i4")),
                                           f["design/control_points"].create_dataset("arc_fraction", data=np.array([0.0, 0.5])),
                                           [f["design/control_points"].attrs.__setitem__(k, v) for k, v in
                                            (("radius_min", 1e-3), ("radius_max", 5e-3), ("radii_at_min", 1),
                                             ("radii_at_max", 0), ("elasticity_min", float("nan")),
                                             ("elasticity_max", 0.0))]),
    # frames (dynamic archives)
    "frames_time_short": lambda f: replace(f, "frames/small/time", f["frames/small/time"][:-1]),
    "frames_two_columns": lambda f: replace(f, "frames/small/positions", f["frames/small/positions"][:, :, :2]),
    "frames_time_backwards": lambda f: f["frames/small/time"].__setitem__(1, -1.0),
    "frames_unknown_pose": lambda f: f["frames"].move("small", "nope"),
}

def global_heap(data, edit):
    """Edits the first object of the first global heap collection (variable-length strings)."""
    at = data.index(b"GCOL\x01")
    b = bytearray(data)
    edit(b, at + 16)  # the first object's header: index, references, reserved, size
    return bytes(b)


def set_size(b, at, value):
    b[at + 8 : at + 16] = value.to_bytes(8, "little")


# Damage to the bytes rather than the structure.
BYTES = {
    # HDF5 1.10 reads past its buffer, or loops for ever, on these.
    "heap_object_huge": lambda b: global_heap(b, lambda h, at: set_size(h, at, 2**40)),
    "heap_free_space_zero": lambda b: global_heap(b, lambda h, at: (h.__setitem__(slice(at, at + 2), b"\0\0"), set_size(h, at, 0))),
    "truncated_half": lambda b: b[: len(b) // 2],
    "truncated_header": lambda b: b[:100],
    "empty": lambda b: b"",
    "superblock_zeroed": lambda b: b[:8] + bytes(64) + b[72:],
}


def main():
    mode, src, dst = sys.argv[1:4]
    if mode in BYTES:
        with open(src, "rb") as f:
            data = f.read()
        with open(dst, "wb") as f:
            f.write(BYTES[mode](data))
        return 0
    if mode not in DAMAGE:
        print("unknown mode " + mode, file=sys.stderr)
        return 2
    shutil.copyfile(src, dst)
    with h5py.File(dst, "r+") as f:
        DAMAGE[mode](f)
    return 0


if __name__ == "__main__":
    sys.exit(main())
