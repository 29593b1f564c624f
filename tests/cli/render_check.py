#!/usr/bin/python3
"""Checks a picture written by scripts/render.py.

    render_check.py PICTURE.png WIDTH HEIGHT [grey=yes|no] [red=yes|no] [green=yes|no] [radius=yes|no]

Reads the PNG (matplotlib's reader), asserts its size in pixels, that it is
not blank, and, for each colour named, that it is present (yes: at least
PRESENT pixels of it) or absent (no: at most ABSENT pixels). The colours are
those of scripts/render.py: the target's translucent grey over white, the
initial design's red, the final positions' green, and the radius colour map
("cool": blue channel 1, red and green not both light). Grey counts only
pixels inside thick grey strokes (text edges are grey too). Prints the pixel
counts; exits 0 when every check passes, 1 otherwise.
"""

import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.image as mpimg  # noqa: E402
import numpy as np  # noqa: E402

PRESENT = 100
ABSENT = 10

# Reference colours (RGB in [0, 1]) and tolerances (largest channel difference).
GREY = (1 - 0.45 * (1 - 0.45),) * 3  # "0.45" at alpha 0.45 over white
RED = (0xD6 / 255, 0x27 / 255, 0x28 / 255)
GREEN = (0x2C / 255, 0xA0 / 255, 0x2C / 255)


def near(rgb, ref, tol):
    return np.abs(rgb - np.asarray(ref)).max(axis=2) <= tol


def count_near(rgb, ref, tol):
    return int(near(rgb, ref, tol).sum())


def count_solid(rgb, ref, tol):
    """Pixels of the colour whose eight neighbours have it too: thick lines
    count, the anti-aliased edges of text (any grey level) do not."""
    m = near(rgb, ref, tol)
    core = m[1:-1, 1:-1].copy()
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            core &= m[1 + dy: m.shape[0] - 1 + dy, 1 + dx: m.shape[1] - 1 + dx]
    return int(core.sum())


def main(argv):
    path, width, height = argv[0], int(argv[1]), int(argv[2])
    wants = dict(a.split("=") for a in argv[3:])
    img = mpimg.imread(path)
    failures = []
    h, w = img.shape[:2]
    if (w, h) != (width, height):
        failures.append(f"size {w} x {h}, expected {width} x {height}")
    rgb = img[:, :, :3].astype(float)
    if img.shape[2] == 4 and float(img[:, :, 3].min()) < 1.0:
        failures.append("the picture has transparent pixels (expected an opaque white background)")
    nonwhite = float((rgb.min(axis=2) < 0.95).mean())
    if nonwhite < 0.01 or float(rgb.std()) < 0.02:
        failures.append(f"blank picture: {100 * nonwhite:.2f}% non-white pixels, std {rgb.std():.4f}")
    counts = {
        "grey": count_solid(rgb, GREY, 0.04),
        "red": count_near(rgb, RED, 0.06),
        "green": count_near(rgb, GREEN, 0.06),
        "radius": int(((rgb[:, :, 2] > 0.97) & (np.minimum(rgb[:, :, 0], rgb[:, :, 1]) < 0.75)).sum()),
    }
    print(f"{path}: {w} x {h}, {100 * nonwhite:.1f}% non-white, pixels: "
          + ", ".join(f"{k} {v}" for k, v in counts.items()))
    for colour, want in wants.items():
        n = counts[colour]
        if want == "yes" and n < PRESENT:
            failures.append(f"{colour}: {n} pixels, expected at least {PRESENT}")
        if want == "no" and n > ABSENT:
            failures.append(f"{colour}: {n} pixels, expected at most {ABSENT}")
    for m in failures:
        print("FAILED: " + m, file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
