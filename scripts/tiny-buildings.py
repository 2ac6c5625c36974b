#!/usr/bin/env python3
"""Write a metric GeoJSON city of N tiny buildings (1 m squares, 4 m apart,
5 m high) on a square grid: a stress case for memory use (every building is
narrower than 2 eps, so nothing occludes and every cell sees every building).

usage: scripts/tiny-buildings.py N OUT.geojson   (bake with --metric)
"""
import json
import math
import sys

n = int(sys.argv[1])
side = math.ceil(math.sqrt(n))
features = []
for k in range(n):
    x, y = (k % side) * 4.0, (k // side) * 4.0
    ring = [[x, y], [x + 1, y], [x + 1, y + 1], [x, y + 1], [x, y]]
    features.append({
        "type": "Feature",
        "properties": {"id": f"t{k}", "height": 5.0},
        "geometry": {"type": "Polygon", "coordinates": [ring]},
    })
with open(sys.argv[2], "w") as f:
    json.dump({"type": "FeatureCollection", "features": features}, f)
