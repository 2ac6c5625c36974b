#!/bin/sh
# Build the fuzz targets with libFuzzer's coverage instrumentation on the
# stable toolchain (what `cargo fuzz build --sanitizer none` does, without
# cargo-fuzz or nightly). The binaries land in
# fuzz/target/x86_64-unknown-linux-gnu/release/{geojson,cityjson,pvs,part,osm,scene,judge,geometry_cache}.
set -eu
cd "$(dirname "$0")"
target=$(rustc -vV | sed -n 's/^host: //p')
RUSTFLAGS="--cfg fuzzing -Cpasses=sancov-module \
 -Cllvm-args=-sanitizer-coverage-level=4 \
 -Cllvm-args=-sanitizer-coverage-inline-8bit-counters \
 -Cllvm-args=-sanitizer-coverage-pc-table \
 -Cllvm-args=-sanitizer-coverage-trace-compares \
 -Cdebug-assertions -Coverflow-checks" \
  cargo build --release --target "$target" --bins "$@"
echo "built: $(pwd)/target/$target/release/{geojson,cityjson,pvs,part,osm,scene,judge,geometry_cache}"
