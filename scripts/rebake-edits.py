#!/usr/bin/env python3
"""Time incremental bakes of five single-building edits against a full bake.

Generates `citypvs generate --buildings 1000 --seed 1` (or reads CITY), bakes
it once, writes five edited copies (raise a row house 6 m, raise a house 6 m,
lower a row house 5 m, delete a row house, move a house 1.7 m east: the
middle, middle, first-third, two-thirds and first-third building of its
kind) and, for each, times `bake EDIT --previous BASE.pvs` and a full bake
of the edited city (one thread each, user CPU seconds), checks that the two
files are byte for byte equal, and prints a table with the median ratio.

usage: scripts/rebake-edits.py CITYPVS WORKDIR [CITY.geojson]
"""
import copy
import json
import math
import os
import resource
import statistics
import subprocess
import sys


def run(args):
    """Run a command; return its user CPU seconds and its output."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime
    out = subprocess.run(args, check=True, capture_output=True).stdout
    return resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime - before, out


def main():
    if len(sys.argv) not in (3, 4):
        sys.exit(__doc__)
    exe, work = os.path.abspath(sys.argv[1]), sys.argv[2]
    os.makedirs(work, exist_ok=True)
    os.chdir(work)
    if len(sys.argv) == 4:
        city = os.path.abspath(sys.argv[3])
    else:
        city = "city.geojson"
        subprocess.run([exe, "generate", "--buildings", "1000", "--seed", "1",
                        "-o", city], check=True, stdout=subprocess.DEVNULL)
    bake = [exe, "bake", "--threads", "1", "-q"]
    run(bake + [city, "-o", "base.pvs"])
    data = json.load(open(city))
    feats = data["features"]
    kind = lambda k: [i for i, f in enumerate(feats)
                      if f["properties"].get("kind") == k]
    # A city without the generator's kinds: any building will do.
    rows = kind("row") or list(range(len(feats)))
    houses = kind("house") or rows

    def height(dh):
        def edit(f, i):
            f[i]["properties"]["height"] += dh
        return edit

    def move(metres):
        def edit(f, i):
            lat = f[i]["geometry"]["coordinates"][0][0][1]
            dlon = metres / (111320.0 * math.cos(math.radians(lat)))
            for ring in f[i]["geometry"]["coordinates"]:
                for p in ring:
                    p[0] += dlon
        return edit

    def delete(f, i):
        del f[i]

    edits = [
        ("raise row house", rows[len(rows) // 2], height(6.0)),
        ("raise house", houses[len(houses) // 2], height(6.0)),
        ("lower row house", rows[len(rows) // 3], height(-5.0)),
        ("delete row house", rows[2 * len(rows) // 3], delete),
        ("move house", houses[len(houses) // 3], move(1.7)),
    ]
    ratios = []
    print("| edit | rebake | full bake | full / rebake | cells solved |")
    print("|---|---|---|---|---|")
    for name, i, edit in edits:
        edited = copy.deepcopy(data)
        edit(edited["features"], i)
        json.dump(edited, open("edit.geojson", "w"))
        inc, out = run(bake + ["edit.geojson", "--previous", "base.pvs",
                               "-o", "inc.pvs", "--json"])
        stats = json.loads(out)
        full, _ = run(bake + ["edit.geojson", "-o", "full.pvs"])
        if open("inc.pvs", "rb").read() != open("full.pvs", "rb").read():
            sys.exit(f"{name}: the incremental bake differs from the full bake")
        ratios.append(full / inc)
        print(f"| {name} | {inc:.2f} s | {full:.2f} s | {full / inc:.2f}x | "
              f"{stats['cells_recomputed']} of {stats['cells']} |")
    print(f"\nmedian full / rebake: {statistics.median(ratios):.2f}x")


if __name__ == "__main__":
    main()
