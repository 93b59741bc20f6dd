"""Plots the examples written by `cargo run --release --example paper_tables -- DIR`: one PNG
per example, the data (dots), the curve they came from (pink) and each method's curve (blue),
in an orthographic view centred on the data, as the GLS-PIA paper's Figures 7-12.

Usage: python3 scripts/paper_plot.py DIR OUT_DIR   (needs matplotlib)
"""

import json
import math
import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def frame(points):
    """An orthonormal (e1, e2) tangent to the sphere at the data's mean direction."""
    m = [sum(p[i] for p in points) for i in range(3)]
    n = math.sqrt(sum(x * x for x in m)) or 1.0
    c = [x / n for x in m]
    a = [0.0, 0.0, 1.0] if abs(c[2]) < 0.9 else [1.0, 0.0, 0.0]
    e1 = [a[1] * c[2] - a[2] * c[1], a[2] * c[0] - a[0] * c[2], a[0] * c[1] - a[1] * c[0]]
    n1 = math.sqrt(sum(x * x for x in e1))
    e1 = [x / n1 for x in e1]
    e2 = [c[1] * e1[2] - c[2] * e1[1], c[2] * e1[0] - c[0] * e1[2], c[0] * e1[1] - c[1] * e1[0]]
    return e1, e2


def project(rows, e1, e2):
    xs = [sum(p[i] * e1[i] for i in range(3)) for p in rows]
    ys = [sum(p[i] * e2[i] for i in range(3)) for p in rows]
    return xs, ys


def plot(doc, out):
    e1, e2 = frame(doc["points"])
    px, py = project(doc["points"], e1, e2)
    tx, ty = project(doc["truth"], e1, e2)
    panels = [("Ground truth and data", None, None)] + [
        (f["label"], f["samples"], f["max_error_rad"]) for f in doc["fits"]
    ]
    cols = 4
    rows = (len(panels) + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(4 * cols, 3.4 * rows), squeeze=False)
    for ax, (label, samples, err) in zip(axes.flat, panels):
        ax.plot(tx, ty, color="#f4a6c6", linewidth=2.5, zorder=1)
        ax.scatter(px, py, s=4, color="#1f4e9c", zorder=3)
        if samples is not None:
            sx, sy = project(samples, e1, e2)
            ax.plot(sx, sy, color="#2a7fff", linewidth=1.0, zorder=2)
            label = f"{label}\nmax error {err:.2e} rad"
        ax.set_title(label, fontsize=9)
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])
    for ax in list(axes.flat)[len(panels):]:
        ax.axis("off")
    fig.suptitle(doc["title"])
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)


def main():
    src, dst = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
    dst.mkdir(parents=True, exist_ok=True)
    for path in sorted(src.glob("*.json")):
        doc = json.loads(path.read_text())
        plot(doc, dst / f"{doc['name']}.png")
        print(f"wrote {dst / (doc['name'] + '.png')}")


if __name__ == "__main__":
    main()
