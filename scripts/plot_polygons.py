#!/usr/bin/env python3
"""Draws an input polygon dataset and its fit as an SVG, to look at (no plotting library needed).

    python3 scripts/plot_polygons.py IN.geojson FIT.geojson OUT.svg [--pole south|north]

Two panels: the GeoJSON as written, in longitude/latitude (plate carree: the ±180 cut and a
polar closure show as straight edges), and an azimuthal equidistant view centred on a pole,
where a ring around that pole is the closed region it is on the sphere. Input outlines are
grey, fitted outlines red; a polygon's fill shows which side is inside (even-odd).
"""
import json
import math
import sys


def polygons(doc):
    """Every polygon (a list of rings of [lon, lat]) in a GeoJSON object."""
    kind = doc.get("type")
    if kind == "FeatureCollection":
        for f in doc["features"]:
            yield from polygons(f)
    elif kind == "Feature":
        if doc.get("geometry"):
            yield from polygons(doc["geometry"])
    elif kind == "GeometryCollection":
        for g in doc["geometries"]:
            yield from polygons(g)
    elif kind == "Polygon":
        yield doc["coordinates"]
    elif kind == "MultiPolygon":
        yield from doc["coordinates"]


def plate_carree(lat_min, lat_max):
    """Longitude/latitude to the unit square, latitudes lat_min..lat_max filling its height."""

    def project(lon, lat):
        return (lon + 180.0) / 360.0, (lat_max - lat) / (lat_max - lat_min)

    return project


def azimuthal(pole, reach_deg):
    """Azimuthal equidistant about a pole, to the unit square (reach_deg from the pole on the
    edge)."""
    s = -1.0 if pole == "south" else 1.0

    def project(lon, lat):
        r = (90.0 - s * lat) / reach_deg * 0.5
        a = math.radians(lon)
        return 0.5 + r * math.sin(a), 0.5 + s * r * math.cos(a)

    return project


def paths(polys, project, x0, y0, w, h):
    out = []
    for poly in polys:
        d = []
        for ring in poly:
            pts = [project(p[0], p[1]) for p in ring]
            d.append("M" + "L".join(f"{x0 + x * w:.2f},{y0 + y * h:.2f}" for x, y in pts) + "Z")
        out.append("".join(d))
    return out


def main():
    args = sys.argv[1:]
    pole = "south"
    if "--pole" in args:
        i = args.index("--pole")
        pole = args[i + 1]
        del args[i : i + 2]
    src, fit, svg = args
    a = list(polygons(json.load(open(src))))
    b = list(polygons(json.load(open(fit))))
    lats = [p[1] for poly in a + b for ring in poly for p in ring]
    lat_min, lat_max = max(-90.0, min(lats) - 2.0), min(90.0, max(lats) + 2.0)
    pc = plate_carree(lat_min, lat_max)
    reach = 1.05 * max(90.0 - (-1.0 if pole == "south" else 1.0) * lat for lat in lats)
    W, H, pad = 1400, 720, 20
    pw, ph = 840, 420
    aw = 520
    parts = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" viewBox="0 0 {W} {H}">',
        '<rect width="100%" height="100%" fill="white"/>',
        f'<text x="{pad}" y="16" font-family="sans-serif" font-size="13">'
        f"{src} (grey) and {fit} (red): lon/lat as written (latitudes {lat_min:.0f} to {lat_max:.0f}), "
        f"and about the {pole} pole (to {reach:.0f} degrees from it)</text>",
    ]
    # Panel 1: lon/lat.
    x0, y0 = pad, 30
    parts.append(f'<rect x="{x0}" y="{y0}" width="{pw}" height="{ph}" fill="none" stroke="#ccc"/>')
    for d in paths(a, pc, x0, y0, pw, ph):
        parts.append(f'<path d="{d}" fill="#999" fill-opacity="0.25" fill-rule="evenodd" stroke="#666" stroke-width="1.6"/>')
    for d in paths(b, pc, x0, y0, pw, ph):
        parts.append(f'<path d="{d}" fill="#d33" fill-opacity="0.15" fill-rule="evenodd" stroke="#d00" stroke-width="0.7"/>')
    # Panel 2: about the pole.
    x1, y1 = pad * 2 + pw, 30
    proj = azimuthal(pole, reach)
    parts.append(f'<circle cx="{x1 + aw / 2}" cy="{y1 + aw / 2}" r="{aw / 2}" fill="none" stroke="#ccc"/>')
    for d in paths(a, proj, x1, y1, aw, aw):
        parts.append(f'<path d="{d}" fill="#999" fill-opacity="0.25" fill-rule="evenodd" stroke="#666" stroke-width="1.6"/>')
    for d in paths(b, proj, x1, y1, aw, aw):
        parts.append(f'<path d="{d}" fill="#d33" fill-opacity="0.15" fill-rule="evenodd" stroke="#d00" stroke-width="0.7"/>')
    parts.append("</svg>")
    with open(svg, "w") as f:
        f.write("\n".join(parts) + "\n")


if __name__ == "__main__":
    main()
