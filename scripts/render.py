#!/usr/bin/python3
"""Pictures of a rodmesh result archive (HDF5, "rodmesh-archive/1").

    scripts/render.py ARCHIVE.h5 -o fig.png [--pose NAME] [--view iso|top|front|side]

One panel per pose (or only --pose NAME): the target in translucent grey (when
the pose has one), the initial design's equilibrium in red (when the archive
has /poses/NAME/initial_positions, written by optimize), and the final
equilibrium positions in green. A last panel shows the rest shape coloured by
radius (r_n by default, --radius t for r_t), with a colour bar in millimetres.

Panels are laid out four to a row, each --panel-size inches square at --dpi
(default 4 in at 100 dpi: 400 x 400 pixels per panel). Rods are drawn as their
centrelines; coordinates are shown in millimetres. Needs Debian's
python3-matplotlib, python3-h5py and python3-numpy; runs headless (Agg).

The colour map of the radius panel ("cool", cyan to magenta) contains none of
the grey, red and green used for the poses, so that a picture can be checked
for them (tests/cli/render_check.py).
"""

import argparse
import json
import math
import os
import sys

os.environ.setdefault("MPLBACKEND", "Agg")

import h5py  # noqa: E402
import numpy as np  # noqa: E402
import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Line3DCollection  # noqa: E402

TARGET = dict(color="0.45", alpha=0.45, linewidth=4.5)
INITIAL = dict(color="#d62728", linewidth=1.8, linestyle=(0, (4, 2)))
FINAL = dict(color="#2ca02c", linewidth=2.2)
RADIUS_CMAP = "cool"

# (elevation, azimuth) in degrees for mplot3d's view_init.
VIEWS = {
    "iso": (25.0, -60.0),
    "top": (90.0, -90.0),  # looking down -z: x to the right, y up
    "front": (0.0, -90.0),  # looking along +y: x to the right, z up
    "side": (0.0, 0.0),  # looking along -x: y to the right, z up
}


class BadInput(Exception):
    pass


def read_archive(path):
    """Rods (lists of vertex indices), rest positions, radii and poses of an archive."""
    try:
        f = h5py.File(path, "r")
    except OSError as e:
        raise BadInput(f"{path}: cannot open as HDF5 ({e})")
    with f:
        fmt = f.attrs.get("format", "")
        if isinstance(fmt, bytes):
            fmt = fmt.decode()
        if fmt != "rodmesh-archive/1" or "scene" not in f:
            raise BadInput(f"{path}: not a rodmesh archive (format attribute {fmt!r})")
        scene_text = f["scene"][()]
        if isinstance(scene_text, bytes):
            scene_text = scene_text.decode("utf-8")
        scene = json.loads(scene_text)
        rods = [list(r["vertices"]) for r in scene["rods"]]
        rest = f["rest/positions"][()] if "rest/positions" in f else np.asarray(scene["vertices"], float)
        if "design/radii" in f:
            radii = f["design/radii"][()]
        elif "radii" in scene:
            radii = np.asarray(scene["radii"], float)
        else:
            radii = np.tile(np.asarray(scene["radius"], float), (len(rest), 1))
        poses = []
        for name in f["poses"] if "poses" in f else []:
            g = f["poses"][name]
            poses.append(
                dict(
                    name=name,
                    positions=g["positions"][()],
                    target=g["target"][()] if "target" in g else None,
                    initial=g["initial_positions"][()] if "initial_positions" in g else None,
                    rms=g.attrs.get("rms_error"),
                )
            )
        # Keep the archive's creation order when it is tracked (h5py lists by name otherwise).
        order = [p["name"] for p in scene.get("poses", [])]
        poses.sort(key=lambda p: order.index(p["name"]) if p["name"] in order else len(order))
    return rods, np.asarray(rest, float), np.asarray(radii, float), poses


def segments(rods, x):
    """Line3DCollection segments, one polyline per rod, in millimetres."""
    return [1e3 * x[r] for r in rods]


def set_equal_box(ax, points_mm):
    lo, hi = points_mm.min(axis=0), points_mm.max(axis=0)
    centre, half = 0.5 * (lo + hi), 0.5 * max(float((hi - lo).max()), 1e-9) * 1.05
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1, 1, 1), zoom=1.0)


# The axis seen end-on in each view: no ticks or label.
HIDDEN_AXIS = {"iso": None, "top": "z", "front": "y", "side": "x"}


def style_axes(ax, view):
    ax.view_init(*VIEWS[view])
    for name, axis in zip("xyz", (ax.xaxis, ax.yaxis, ax.zaxis)):
        axis.set_pane_color((1.0, 1.0, 1.0, 0.0))
        axis._axinfo["grid"]["color"] = (0.9, 0.9, 0.9, 1.0)
        if name == HIDDEN_AXIS[view]:
            axis.set_ticks([])
            axis.line.set_color((1.0, 1.0, 1.0, 0.0))
        else:
            axis.set_label_text(f"{name} [mm]", fontsize=7)
            axis.labelpad = -6
    ax.tick_params(labelsize=6, pad=-2)


def render(archive, out, pose=None, view="iso", radius="n", dpi=100, panel_size=4.0):
    rods, rest, radii, poses = read_archive(archive)
    if pose is not None:
        chosen = [p for p in poses if p["name"] == pose]
        if not chosen:
            names = ", ".join(p["name"] for p in poses) or "none"
            raise BadInput(f"{archive}: no pose named '{pose}' in the archive (available: {names})")
        poses = chosen
    panels = len(poses) + 1
    cols = min(panels, 4)
    rows = math.ceil(panels / cols)
    fig = plt.figure(figsize=(panel_size * cols, panel_size * rows), dpi=dpi)
    fig.patch.set_facecolor("white")
    fig.subplots_adjust(left=0.02, right=0.96, bottom=0.02, top=0.9, wspace=0.08, hspace=0.12)

    # One box for every panel, so that poses compare at the same scale.
    everything = [rest] + [p[k] for p in poses for k in ("positions", "target", "initial") if p[k] is not None]
    box = 1e3 * np.vstack(everything)

    for i, p in enumerate(poses):
        ax = fig.add_subplot(rows, cols, i + 1, projection="3d")
        style_axes(ax, view)
        handles = []
        if p["target"] is not None:
            ax.add_collection3d(Line3DCollection(segments(rods, p["target"]), capstyle="round", **TARGET))
            handles.append(Line2D([], [], label="target", **TARGET))
        if p["initial"] is not None:
            ax.add_collection3d(Line3DCollection(segments(rods, p["initial"]), **INITIAL))
            handles.append(Line2D([], [], label="initial design", **INITIAL))
        ax.add_collection3d(Line3DCollection(segments(rods, p["positions"]), **FINAL))
        handles.append(Line2D([], [], label="final", **FINAL))
        set_equal_box(ax, box)
        title = f"pose '{p['name']}'"
        if p["rms"] is not None:
            title += f"\nRMS error {1e3 * float(p['rms']):.3g} mm"
        ax.set_title(title, fontsize=9)
        ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, 1.0), ncol=len(handles), fontsize=7,
                  frameon=False)

    ax = fig.add_subplot(rows, cols, len(poses) + 1, projection="3d")
    style_axes(ax, view)
    col = 1 if radius == "n" else 0
    segs, vals = [], []  # one segment per edge, coloured by the mean radius of its two vertices
    for r in rods:
        x, rr = 1e3 * rest[r], 1e3 * radii[r, col]
        segs.extend(np.stack([x[:-1], x[1:]], axis=1))
        vals.extend(0.5 * (rr[:-1] + rr[1:]))
    vals = np.asarray(vals, float)
    lo, hi = float(vals.min()), float(vals.max())
    if hi - lo < 1e-9 * max(abs(hi), 1e-12):
        lo, hi = 0.9 * lo, 1.1 * hi
    lc = Line3DCollection(segs, cmap=RADIUS_CMAP, linewidth=3.0, capstyle="butt")
    lc.set_array(vals)
    lc.set_clim(lo, hi)
    ax.add_collection3d(lc)
    set_equal_box(ax, box)
    ax.set_title(f"rest shape, radius r_{radius}", fontsize=9)
    bar = fig.colorbar(lc, ax=ax, shrink=0.6, pad=0.08)
    bar.set_label(f"r_{radius} [mm]", fontsize=8)
    bar.ax.tick_params(labelsize=7)

    # Written next to the target and renamed when complete: no partial picture.
    tmp = f"{out}.tmp.{os.getpid()}.png"
    try:
        fig.savefig(tmp, dpi=dpi, facecolor="white")
        os.replace(tmp, out)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
        plt.close(fig)
    return fig.get_size_inches() * dpi


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("archive", help="result archive (HDF5) from rodmesh simulate or optimize")
    ap.add_argument("-o", "--output", required=True, help="picture to write (.png)")
    ap.add_argument("--pose", help="draw only this pose")
    ap.add_argument("--view", choices=sorted(VIEWS), default="iso", help="viewing direction (default iso)")
    ap.add_argument("--radius", choices=["n", "t"], default="n", help="radius that colours the rest shape (default n)")
    ap.add_argument("--dpi", type=float, default=100.0, help="pixels per inch (default 100)")
    ap.add_argument("--panel-size", type=float, default=4.0, help="panel width and height in inches (default 4)")
    args = ap.parse_args(argv)
    try:
        if not args.output.lower().endswith(".png"):
            raise BadInput(f"{args.output}: the picture must be a .png file")
        d = os.path.dirname(os.path.abspath(args.output))
        if not os.path.isdir(d) or not os.access(d, os.W_OK):
            raise BadInput(f"{args.output}: directory {d} does not exist or is not writable")
        if args.dpi <= 0 or args.panel_size <= 0:
            raise BadInput("--dpi and --panel-size must be positive")
        w, h = render(args.archive, args.output, args.pose, args.view, args.radius, args.dpi, args.panel_size)
    except BadInput as e:
        print(f"render.py: error: {e}", file=sys.stderr)
        return 2
    print(f"wrote {args.output} ({int(round(w))} x {int(round(h))} pixels)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
