#!/usr/bin/python3
"""Checks rodmesh's ParaView outputs against the archive they came from.

Run by tests/cli/visualization_cli_test.cc; exits 0 when every check passes,
1 with the failed checks on stderr otherwise.

    vtk_check.py vtp ARCHIVE.h5 FILE.vtp [POSE]       rest shape, or POSE's final positions
    vtk_check.py poses ARCHIVE.h5 OUT.pvd             --all-poses collection
    vtk_check.py frames ARCHIVE.h5 OUT.pvd POSE       frames of a dynamic pose
    vtk_check.py xdmf ARCHIVE.h5 FILE.xmf [POSE]      XDMF side file (of POSE's frames)

.vtp files are read with VTK's own reader (vtkXMLPolyDataReader, Debian's
python3-vtk9); the archive with h5py. A .pvd is an index: its entries are
parsed as XML and every file it names is read with VTK. The .xmf is parsed as
XML and every HDF5 reference in it is resolved in the archive.
"""

import json
import os
import sys
import xml.etree.ElementTree as ET

import h5py
import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOXML import vtkXMLPolyDataReader

failures = []


def check(cond, what):
    if not cond:
        failures.append(what)
    return cond


def close(a, b):
    return np.shape(a) == np.shape(b) and np.array_equal(np.asarray(a, float), np.asarray(b, float))


def load_archive(path):
    f = h5py.File(path, "r")
    scene_text = f["scene"][()]
    scene = json.loads(scene_text.decode("utf-8") if isinstance(scene_text, bytes) else scene_text)
    return f, scene


def read_vtp(path):
    check(os.path.isfile(path), f"{path} exists")
    r = vtkXMLPolyDataReader()
    r.SetFileName(path)
    r.Update()
    check(r.GetErrorCode() == 0, f"{path}: VTK reader error code {r.GetErrorCode()}")
    return r.GetOutput()


def point_arrays(poly):
    pd = poly.GetPointData()
    return {pd.GetArrayName(i): vtk_to_numpy(pd.GetArray(i)) for i in range(pd.GetNumberOfArrays())}


def check_polydata(poly, f, scene, positions, target, label):
    """The PolyData of shape `positions`, with `target` (or None)."""
    rods = [r["vertices"] for r in scene["rods"]]
    rest = f["rest/positions"][()]
    radii = f["design/radii"][()]
    nv = rest.shape[0]
    check(poly.GetNumberOfPoints() == nv, f"{label}: {poly.GetNumberOfPoints()} points, archive has {nv} vertices")
    check(poly.GetNumberOfCells() == len(rods), f"{label}: {poly.GetNumberOfCells()} cells for {len(rods)} rods")
    check(poly.GetNumberOfLines() == len(rods), f"{label}: {poly.GetNumberOfLines()} lines for {len(rods)} rods")
    if poly.GetNumberOfPoints() != nv:
        return
    pts = vtk_to_numpy(poly.GetPoints().GetData())
    check(close(pts, positions), f"{label}: points equal the archived positions")
    for c in range(min(poly.GetNumberOfCells(), len(rods))):
        cell = poly.GetCell(c)
        ids = [cell.GetPointId(k) for k in range(cell.GetNumberOfPoints())]
        check(cell.GetCellType() == 4, f"{label}: cell {c} is a VTK_POLY_LINE (type {cell.GetCellType()})")
        check(ids == rods[c], f"{label}: cell {c} runs through rod {c}'s vertices {rods[c]} (got {ids})")
    arrays = point_arrays(poly)
    expected = {"radius_t", "radius_n", "displacement"} | ({"error"} if target is not None else set())
    check(set(arrays) == expected, f"{label}: point arrays {sorted(arrays)}, expected {sorted(expected)}")
    if "radius_t" in arrays:
        check(close(arrays["radius_t"], radii[:, 0]), f"{label}: radius_t equals /design/radii[:, 0]")
    if "radius_n" in arrays:
        check(close(arrays["radius_n"], radii[:, 1]), f"{label}: radius_n equals /design/radii[:, 1]")
    if "displacement" in arrays:
        check(arrays["displacement"].shape == (nv, 3), f"{label}: displacement has 3 components")
        check(np.allclose(arrays["displacement"], positions - rest, rtol=0, atol=1e-15),
              f"{label}: displacement equals positions - /rest/positions")
    if "error" in arrays and target is not None:
        err = np.linalg.norm(positions - target, axis=1)
        check(np.allclose(arrays["error"], err, rtol=1e-12, atol=1e-15), f"{label}: error equals |q - target|")
    cd = poly.GetCellData()
    rod = cd.GetArray("rod")
    check(cd.GetNumberOfArrays() == 1 and rod is not None, f"{label}: one cell array, 'rod'")
    if rod is not None:
        check(list(vtk_to_numpy(rod)) == list(range(len(rods))), f"{label}: cell array rod is 0..{len(rods) - 1}")


def pose_data(f, name):
    g = f["poses"][name]
    return g["positions"][()], (g["target"][()] if "target" in g else None)


def read_pvd(path):
    root = ET.parse(path).getroot()
    check(root.tag == "VTKFile" and root.get("type") == "Collection", f"{path} is a VTK collection")
    entries = root.findall("./Collection/DataSet")
    return [(float(e.get("timestep")), e.get("name"), os.path.join(os.path.dirname(path), e.get("file"))) for e in entries]


def cmd_vtp(archive, vtp, pose=None):
    f, scene = load_archive(archive)
    if pose:
        positions, target = pose_data(f, pose)
    else:
        positions, target = f["rest/positions"][()], None
    check_polydata(read_vtp(vtp), f, scene, positions, target, vtp)


def cmd_poses(archive, pvd):
    f, scene = load_archive(archive)
    entries = read_pvd(pvd)
    names = [p["name"] for p in scene["poses"]]
    check(len(entries) == 1 + len(names), f"{pvd}: {len(entries)} entries for the rest shape and {len(names)} poses")
    check([e[0] for e in entries] == list(range(len(entries))), f"{pvd}: timesteps 0, 1, ...")
    check([e[1] for e in entries] == ["rest"] + names, f"{pvd}: entry names {[e[1] for e in entries]}")
    for k, (_, name, file) in enumerate(entries):
        if k == 0:
            check_polydata(read_vtp(file), f, scene, f["rest/positions"][()], None, file)
        elif name in f["poses"]:
            positions, target = pose_data(f, name)
            check_polydata(read_vtp(file), f, scene, positions, target, file)


def cmd_frames(archive, pvd, pose):
    f, scene = load_archive(archive)
    frames = f["frames"][pose]["positions"][()]
    time = f["frames"][pose]["time"][()]
    target = f["poses"][pose]["target"][()] if "target" in f["poses"][pose] else None
    entries = read_pvd(pvd)
    check(len(entries) == frames.shape[0], f"{pvd}: {len(entries)} entries for {frames.shape[0]} frames")
    check(close([e[0] for e in entries], time), f"{pvd}: timesteps equal /frames/{pose}/time")
    for t, (_, _, file) in enumerate(entries[: frames.shape[0]]):
        poly = read_vtp(file)
        check_polydata(poly, f, scene, frames[t], target, file)
        tv = poly.GetFieldData().GetArray("TimeValue")
        check(tv is not None and tv.GetValue(0) == time[t], f"{file}: field data TimeValue = {time[t]}")


def resolve(item, f, xmf_dir, archive):
    """The array a DataItem stands for (HDF references, inline XML, hyperslabs, $0 - $1)."""
    kind = item.get("ItemType", "Uniform")
    dims = [int(d) for d in item.get("Dimensions").split()]
    if kind == "HyperSlab":
        sel, data = list(item)
        s = np.array(sel.text.split(), int).reshape(3, -1)
        a = resolve(data, f, xmf_dir, archive)
        idx = tuple(slice(s[0, k], s[0, k] + s[1, k] * s[2, k], s[1, k]) for k in range(a.ndim))
        return a[idx].reshape(dims)
    if kind == "Function":
        check(item.get("Function").replace(" ", "") == "$0-$1", f"function {item.get('Function')}")
        a, b = (resolve(c, f, xmf_dir, archive) for c in item)
        return (a.reshape(-1) - b.reshape(-1)).reshape(dims)
    if item.get("Format") == "HDF":
        file, dataset = item.text.strip().rsplit(":", 1)
        check(os.path.samefile(os.path.join(xmf_dir, file), archive), f"HDF reference {file} is the archive")
        check(dataset in f, f"dataset {dataset} exists in the archive")
        a = f[dataset][()]
        check(list(a.shape) == dims, f"{dataset}: Dimensions {dims}, stored {list(a.shape)}")
        return a
    a = np.array(item.text.split(), float)
    check(a.size == np.prod(dims), f"inline data item has {a.size} values for Dimensions {dims}")
    return a.reshape(dims)


def cmd_xdmf(archive, xmf, frames_of=None):
    f, scene = load_archive(archive)
    root = ET.parse(xmf).getroot()
    xdir = os.path.dirname(os.path.abspath(xmf))
    domain = root.find("Domain")
    rods = [r["vertices"] for r in scene["rods"]]
    topo = domain.find("Topology")
    check(topo.get("TopologyType") == "Mixed" and int(topo.get("NumberOfElements")) == len(rods), "Mixed topology, one cell per rod")
    ids = [int(v) for v in topo.find("DataItem").text.split()]
    cells, k = [], 0
    while k < len(ids):
        check(ids[k] == 2, f"cell type {ids[k]} is 2 (polyline)")
        n = ids[k + 1]
        cells.append(ids[k + 2: k + 2 + n])
        k += 2 + n
    check(cells == rods, "topology: one polyline per rod, through the scene's vertices")

    rest = f["rest/positions"][()]
    radii = f["design/radii"][()]
    expected = [("rest", 0.0, rest, None)]
    names = [p["name"] for p in scene["poses"]]
    for k, n in enumerate(names):
        q, target = pose_data(f, n)
        expected.append((n, float(k + 1), q, target))
    if frames_of:
        fr = f["frames"][frames_of]
        expected = [(f"{frames_of} {t}", float(fr["time"][t]), fr["positions"][t], pose_data(f, frames_of)[1])
                    for t in range(fr["positions"].shape[0])]
    collections = domain.findall("Grid")
    name = f"frames {frames_of}" if frames_of else "shapes"
    check(len(collections) == 1, f"one collection, found {len(collections)}")
    check(collections[0].get("Name") == name and collections[0].get("CollectionType") == "Temporal",
          f"temporal collection '{name}'")
    for gs, exp in [(collections[0].findall("Grid"), expected)]:
        check(len(gs) == len(exp), f"{len(gs)} grids, expected {len(exp)}")
        for g, (name, time, q, target) in zip(gs, exp):
            check(g.get("Name") == name, f"grid name {g.get('Name')} == {name}")
            check(float(g.find("Time").get("Value")) == time, f"grid {name}: time {time}")
            item = g.find("Geometry/DataItem")
            heavy = item if item.get("ItemType") != "HyperSlab" else list(item)[1]
            check(heavy.get("Format") == "HDF", f"grid {name}: geometry is read from the archive, not copied")
            geo = resolve(item, f, xdir, archive)
            check(close(geo.reshape(-1, 3), q), f"grid {name}: geometry equals the archived positions")
            attrs = {a.get("Name"): a for a in g.findall("Attribute")}
            inc = g.find("{http://www.w3.org/2001/XInclude}include")
            check(inc is not None and "Topology[1]" in inc.get("xpointer", ""), f"grid {name}: includes the topology")
            want = {"rod", "radii", "radius_t", "radius_n", "displacement"} | ({"target", "error_vector"} if target is not None else set())
            check(set(attrs) == want, f"grid {name}: attributes {sorted(attrs)}, expected {sorted(want)}")
            if "rod" in attrs:
                check(attrs["rod"].get("Center") == "Cell", f"grid {name}: rod is cell data")
                check(list(resolve(attrs["rod"].find("DataItem"), f, xdir, archive)) == list(range(len(rods))),
                      f"grid {name}: rod values 0..R-1")
            if "radii" in attrs:
                check(close(resolve(attrs["radii"].find("DataItem"), f, xdir, archive), radii),
                      f"grid {name}: radii equals /design/radii")
            for col, n in enumerate(("radius_t", "radius_n")):
                if n in attrs:
                    check(close(resolve(attrs[n].find("DataItem"), f, xdir, archive).reshape(-1), radii[:, col]),
                          f"grid {name}: {n} equals /design/radii[:, {col}]")
            if "displacement" in attrs:
                d = resolve(attrs["displacement"].find("DataItem"), f, xdir, archive).reshape(-1, 3)
                check(np.allclose(d, q - rest, rtol=0, atol=1e-15), f"grid {name}: displacement = q - rest")
            if target is not None and "error_vector" in attrs:
                e = resolve(attrs["error_vector"].find("DataItem"), f, xdir, archive).reshape(-1, 3)
                check(np.allclose(e, q - target, rtol=0, atol=1e-15), f"grid {name}: error_vector = q - target")


def main(argv):
    cmds = {"vtp": cmd_vtp, "poses": cmd_poses, "frames": cmd_frames, "xdmf": cmd_xdmf}
    if len(argv) < 3 or argv[0] not in cmds:
        print(__doc__, file=sys.stderr)
        return 2
    try:
        cmds[argv[0]](*argv[1:])
    except Exception as e:  # a crash is a failed check, with its reason
        failures.append(f"{type(e).__name__}: {e}")
    for m in failures:
        print("FAILED: " + m, file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
