"""Read the measured points of the Eurosprinter creep-force figure of CONTACT's user guide.

Not part of the test suite: it documents, and can repeat, how the ``[measured]`` table of
``eurosprinter_creep.toml`` was obtained. The points (Engel, Beck and Alders 1998,
locomotive 127 001 at 10 m/s) are plotted in CONTACT's user guide as cyan asterisks in
two raster images, ``doc/fig/eurosprinter6.jpg`` (creepage 0-5 %, traction coefficient
0-0.45) and ``doc/fig/eurosprinter5.jpg`` (creepage 0-25 %, 0-0.35), each 875 x 656
pixels, written by CONTACT's ``examples/plot_results.m``. This script:

1. calibrates each image's axes from its light-grey grid lines (their pixel centres are
   fitted with a straight line against the tick values; the residuals are under 0.5 px);
2. marks the cyan pixels (red < 130, green and blue > 100 and within 50 of each other,
   green - red > 50) and takes the asterisk's shape from the isolated markers (13 x 13
   pixels);
3. finds the markers one by one, greedily: a marker is placed where at least 35 % of the
   asterisk's pixels are cyan and at least 75 % are cyan or hidden under something drawn
   on top of the markers (the curves, the annotation lines), and where it explains at
   least 12 cyan pixels no earlier marker explains, no closer than 3 px to an earlier
   one; the legend box is left out;
4. converts the markers' centres to (creepage %, traction coefficient) and keeps the
   points below 4.9 % creepage from the 0-5 % image (5.4 times the resolution) and the
   rest from the 0-25 % image.

Run: ``python tests/physics/data/digitise_eurosprinter.py /path/to/CONTACT.git`` (a git
directory of the repository eve70a/CONTACT); it prints the ``[measured]`` arrays.
Needs Pillow (a matplotlib dependency) and scipy.
"""

from __future__ import annotations

import io
import subprocess
import sys

import numpy as np
from PIL import Image
from scipy import ndimage

# image -> (grid values along x in %, along y in -), the ticks with grid lines inside the box
GRIDS = {
    "doc/fig/eurosprinter6.jpg": ([0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5],
                                  [0.40, 0.35, 0.30, 0.25, 0.20, 0.15, 0.10, 0.05]),
    "doc/fig/eurosprinter5.jpg": ([5.0, 10.0, 15.0, 20.0],
                                  [0.30, 0.25, 0.20, 0.15, 0.10, 0.05]),
}
LEGEND = (480, 470, 780, 580)   # pixels x0, y0, x1, y1 of the legend box (both images)
SPLIT = 4.9                      # %, creepage where the 0-25 % image takes over


def _image(gitdir: str, path: str) -> np.ndarray:
    blob = subprocess.run(["git", "--git-dir", gitdir, "show", f"HEAD:{path}"],
                          check=True, capture_output=True).stdout
    return np.asarray(Image.open(io.BytesIO(blob)).convert("RGB")).astype(int)


def _line_centres(counts: np.ndarray, offset: int, threshold: int) -> list[float]:
    idx = np.nonzero(counts > threshold)[0]
    groups = np.split(idx, np.nonzero(np.diff(idx) > 1)[0] + 1)
    return [offset + float(np.average(g, weights=counts[g])) for g in groups]


def calibrate(im: np.ndarray, xs: list[float], ys: list[float]):
    """Straight lines pixel = slope * value + offset along x and y, from the grid."""
    mean = im.mean(axis=2)
    spread = im.max(axis=2) - im.min(axis=2)
    grey = (mean < 245) & (mean > 150) & (spread < 20)
    inner = grey[60:580, 120:790]          # inside the axes box, clear of its frame
    cx = _line_centres(inner.sum(axis=0), 120, 150)
    cy = _line_centres(inner.sum(axis=1), 60, 200)
    if len(cx) != len(xs) or len(cy) != len(ys):
        raise RuntimeError(f"found {len(cx)} x and {len(cy)} y grid lines, expected "
                           f"{len(xs)} and {len(ys)}")
    return np.polyfit(xs, cx, 1), np.polyfit(ys, cy, 1)


def markers(im: np.ndarray) -> list[tuple[int, int]]:
    """Pixel centres (x, y) of the asterisks."""
    r, g, b = im[..., 0], im[..., 1], im[..., 2]
    cyan = (r < 130) & (g > 100) & (b > 100) & (abs(g - b) < 50) & (g - r > 50)
    covered = ~cyan & ~(im.min(axis=2) > 200)   # drawn over: may hide a marker's pixels
    lab, _ = ndimage.label(cyan, structure=np.ones((3, 3)))
    shapes = [(lab[o] == i + 1).astype(float) for i, o in enumerate(ndimage.find_objects(lab))
              if (o[0].stop - o[0].start, o[1].stop - o[1].start) == (13, 13)]
    star = np.mean(shapes, axis=0) > 0.5
    x0, y0, x1, y1 = LEGEND
    cyan[y0:y1, x0:x1] = False
    n_star = star.sum()
    k = star.astype(float)
    on_cyan = ndimage.correlate(cyan.astype(float), k, mode="constant")
    on_any = ndimage.correlate((cyan | covered).astype(float), k, mode="constant")
    explained = np.zeros_like(cyan)
    sy, sx = np.nonzero(star)
    h, w = star.shape
    found: list[tuple[int, int]] = []
    while True:
        new = ndimage.correlate((cyan & ~explained).astype(float), k, mode="constant")
        ok = (on_any >= 0.75 * n_star) & (on_cyan >= 0.35 * n_star) & (new >= 12)
        score = np.where(ok, on_cyan + 0.5 * new, -1.0)
        for fx, fy in found:
            score[max(fy - 3, 0):fy + 4, max(fx - 3, 0):fx + 4] = -1.0
        if score.max() < 0.0:
            return found
        yc, xc = np.unravel_index(int(np.argmax(score)), score.shape)
        found.append((int(xc), int(yc)))
        explained[sy + yc - h // 2, sx + xc - w // 2] = True


def main(gitdir: str) -> None:
    points = []
    for path, (xs, ys) in GRIDS.items():
        im = _image(gitdir, path)
        px, py = calibrate(im, xs, ys)
        for x, y in markers(im):
            xi = (x - px[1]) / px[0]
            f = (y - py[1]) / py[0]
            zoomed = path.endswith("6.jpg")
            if (xi < SPLIT) == zoomed:
                points.append((xi, f))
    points.sort()
    print(f"# {len(points)} points")
    print("creepage_percent = [" + ", ".join(f"{p[0]:.3f}" for p in points) + "]")
    print("traction_coefficient = [" + ", ".join(f"{p[1]:.4f}" for p in points) + "]")


if __name__ == "__main__":
    main(sys.argv[1])
