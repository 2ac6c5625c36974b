#!/usr/bin/env bash
# Regenerate the README pictures in docs/pictures/ from the default city
# (the one `citypvs bake` bakes with no CITY: 400 generated buildings, seed 1).
#
#   scripts/readme-pictures.sh [OUTPUT_DIR]     (default: docs/pictures)
#
# Each picture is drawn 1,600 px wide; if its PNG is 300 KB or more it is
# drawn again narrower (1,400 then 1,200 px) so the repository stays small.
set -euo pipefail

cd "$(dirname "$0")/.."
out_dir="${1:-docs/pictures}"
mkdir -p "$out_dir"

cargo build --release --quiet
citypvs=target/release/citypvs
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

city="$work/default-city.geojson"
pvs="$work/default-city.pvs"
"$citypvs" generate --buildings 400 --seed 1 -o "$city"
"$citypvs" bake "$city" -o "$pvs" --quiet

# A street near the city's centre (lon, lat): 5 m west and 5 m south of the
# generator's origin, about 6 m from the nearest wall.
street="24.938310,60.169855"
max_bytes=$((300 * 1024))

# picture NAME [render options...]: draw docs/pictures/NAME.png under 300 KB.
picture() {
  local name="$1"
  shift
  local file="$out_dir/$name.png"
  for size in 1600 1400 1200; do
    "$citypvs" render "$city" --pvs "$pvs" --size "$size" -o "$file" "$@"
    if [ "$(wc -c <"$file")" -lt "$max_bytes" ]; then
      return 0
    fi
    echo "$file is $(wc -c <"$file") bytes at $size px; drawing it narrower" >&2
  done
  echo "warning: $file is still $(wc -c <"$file") bytes (limit $max_bytes)" >&2
}

# 1. Street level: one cell, what it sees and what it culls, its sample
#    points, its cull map and the shrunk occluders, 150 m around it.
picture street-cell --at="$street" --layer cullmap --radius 150
# 2. The same cell's visible set over the whole city.
picture city-cell --at="$street"
# 3. Every cell coloured by the size of its PVS.
picture city-pvs-size --layer pvs-size

ls -l "$out_dir"/*.png
