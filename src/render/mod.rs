//! PNG pictures of a city, its cells, a cell's PVS and its cull map (tiny-skia).
