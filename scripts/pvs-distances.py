#!/usr/bin/env python3
"""How far away the buildings in a baked PVS are.

Reads CELLS cells spread evenly over the file's cell order (default 300;
cells are stored in Morton order, so they are spread over the city) with
`citypvs inspect --json --cell N`, and for each visible building the
distance from the cell's centroid to the mean of its footprint's outer
vertices, both in lon/lat from the city's GeoJSON and the cell's
`triangle_input`, measured on a local equirectangular projection (good to
well under 1 % over a city). Prints the mean PVS and how many of a cell's
visible buildings lie in each distance band, with how many of those are at
least 30 m tall.

Only for lon/lat GeoJSON cities of polygons whose features carry the ids
the bake names them by (as `citypvs generate` writes them).

usage: scripts/pvs-distances.py CITYPVS CITY.geojson FILE.pvs [CELLS]
"""
import json
import math
import subprocess
import sys

BANDS = [0, 100, 200, 400, 800, 1600, math.inf]


def inspect(citypvs, pvs, cell):
    out = subprocess.run(
        [citypvs, "inspect", pvs, "--json", "--cell", str(cell)],
        check=True,
        capture_output=True,
    ).stdout
    return json.loads(out)


def main():
    if len(sys.argv) not in (4, 5):
        sys.exit(__doc__)
    citypvs, city, pvs = sys.argv[1:4]
    cells_wanted = int(sys.argv[4]) if len(sys.argv) == 5 else 300
    first = inspect(citypvs, pvs, 0)
    frame = first["header"]["frame"]
    if frame.get("kind") != "lon_lat":
        sys.exit(f"{pvs}: the frame is not lon/lat")
    lat0 = math.radians(frame["lat0"])
    # Metres per degree of longitude and latitude at lat0.
    kx, ky = 111_320.0 * math.cos(lat0), 110_540.0
    with open(city) as f:
        features = json.load(f)["features"]
    where, height = {}, {}
    for feature in features:
        ring = feature["geometry"]["coordinates"][0][:-1]
        x = sum(p[0] for p in ring) / len(ring)
        y = sum(p[1] for p in ring) / len(ring)
        where[feature["id"]] = (x * kx, y * ky)
        height[feature["id"]] = feature["properties"].get("height", 0.0)
    cells = first["stats"]["cells"]
    count = min(cells_wanted, cells)
    per_band = [0] * (len(BANDS) - 1)
    tall = [0] * (len(BANDS) - 1)
    pairs = 0
    for k in range(count):
        cell = inspect(citypvs, pvs, k * cells // count)["cells"][0]
        corners = cell["triangle_input"]
        cx = sum(p[0] for p in corners) / 3 * kx
        cy = sum(p[1] for p in corners) / 3 * ky
        for b in cell["visible"]:
            x, y = where[b]
            d = math.hypot(x - cx, y - cy)
            band = next(i for i in range(len(BANDS) - 1) if d < BANDS[i + 1])
            per_band[band] += 1
            tall[band] += height[b] >= 30.0
            pairs += 1
    print(f"{pvs}: {count} cells, mean PVS {pairs / count:.1f}")
    print("distance       per cell  share  of them >= 30 m tall")
    for i in range(len(BANDS) - 1):
        hi = "" if BANDS[i + 1] == math.inf else str(BANDS[i + 1])
        print(
            f"{BANDS[i]:>5}-{hi:<5} m  {per_band[i] / count:8.1f}"
            f"  {100 * per_band[i] / pairs:4.1f}%  {tall[i] / count:8.1f}"
        )


if __name__ == "__main__":
    main()
