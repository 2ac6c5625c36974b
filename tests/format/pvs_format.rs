//! The `.pvs` file: round trip, atomic writing, point lookup, and clear errors
//! for truncated or corrupted files.

use citypvs::ErrorKind;
use citypvs::input::Frame;
use citypvs::pvs::{BakeInfo, PvsData, PvsReader, encode_pvs, write_pvs};
use glam::DVec2;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn info(frame: Frame) -> BakeInfo {
    BakeInfo {
        numbers: crate::common::test_numbers(),
        frame,
        source_hash: std::array::from_fn(|i| (i * 7 + 3) as u8),
        region_hash: [0; 32],
        tool_version: "citypvs 0.1.0-test".into(),
    }
}

/// A strip of `n` squares, each split into two CCW triangles, with varied visible sets.
fn strip(squares: usize, objects: usize, frame: Frame) -> PvsData {
    let mut cells = Vec::new();
    for k in 0..squares {
        let x = k as f64 * 10.0;
        let (a, b, c, d) = (
            DVec2::new(x, 0.0),
            DVec2::new(x + 10.0, 0.0),
            DVec2::new(x + 10.0, 10.0),
            DVec2::new(x, 10.0),
        );
        cells.push([a, b, c]);
        cells.push([a, c, d]);
    }
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let visible = (0..cells.len())
        .map(|c| match c % 4 {
            0 => Vec::new(),
            1 => (0..objects as u32).collect(),
            2 => (0..objects as u32)
                .filter(|_| rng.random_bool(0.1))
                .collect(),
            _ => (c as u32 % 5..objects as u32).step_by(3).collect(),
        })
        .collect();
    PvsData {
        object_prints: Vec::new(),
        info: info(frame),
        object_ids: (0..objects)
            .map(|i| format!("way/{}", 1000 + i * 13))
            .collect(),
        cells,
        visible,
    }
}

fn read_back(reader: &PvsReader) -> PvsData {
    PvsData {
        object_prints: Vec::new(),
        info: reader.info().clone(),
        object_ids: reader.object_ids().to_vec(),
        cells: (0..reader.cell_count())
            .map(|c| reader.cell_triangle(c))
            .collect(),
        visible: (0..reader.cell_count())
            .map(|c| reader.visible(c).unwrap())
            .collect(),
    }
}

#[test]
fn round_trip_equals_the_data_for_every_frame_kind() {
    let dir = tempfile::tempdir().unwrap();
    let frames = [
        Frame::LonLat {
            lon0: 26.94,
            lat0: 60.47,
        },
        Frame::Metric {
            origin: DVec2::new(491_234.5, 6_702_345.25),
            crs: Some("urn:ogc:def:crs:EPSG::3067".into()),
        },
        Frame::Metric {
            origin: DVec2::new(-5.0, 7.5),
            crs: None,
        },
    ];
    for (k, frame) in frames.into_iter().enumerate() {
        let data = strip(25, 37 + k * 50, frame);
        let path = dir.path().join(format!("t{k}.pvs"));
        let stats = write_pvs(&path, &data).unwrap();
        assert_eq!(stats.file_bytes, std::fs::metadata(&path).unwrap().len());
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(stats.checksum[..], bytes[bytes.len() - 32..]);
        let reader = PvsReader::open(&path).unwrap();
        assert_eq!(read_back(&reader), data);
        assert_eq!(reader.file_bytes(), stats.file_bytes);
        let ids = reader.visible_ids(1).unwrap();
        assert_eq!(ids.len(), data.object_ids.len());
        assert_eq!(ids[0], data.object_ids[0]);
    }
}

#[test]
fn block_sets_give_every_cell_of_each_block_in_order() {
    let data = strip(
        700,
        90,
        Frame::LonLat {
            lon0: 26.94,
            lat0: 60.47,
        },
    );
    let reader = PvsReader::from_bytes(encode_pvs(&data).unwrap().0).unwrap();
    let blocks = reader.cell_count().div_ceil(reader.block_cells());
    assert!(blocks >= 3, "the strip spans several blocks");
    let mut all = Vec::new();
    for b in 0..blocks {
        let sets = reader.block_sets(b).unwrap();
        assert!(sets.len() <= reader.block_cells());
        all.extend(sets);
    }
    assert_eq!(all, data.visible);
    crate::common::error_of(reader.block_sets(blocks), ErrorKind::Format);
}

#[test]
fn empty_data_round_trips() {
    let data = PvsData {
        object_prints: Vec::new(),
        info: info(Frame::LonLat {
            lon0: 0.0,
            lat0: 0.0,
        }),
        object_ids: Vec::new(),
        cells: Vec::new(),
        visible: Vec::new(),
    };
    let (bytes, _) = encode_pvs(&data).unwrap();
    let reader = PvsReader::from_bytes(bytes).unwrap();
    assert_eq!(read_back(&reader), data);
    assert_eq!(reader.cell_at(DVec2::ZERO), None);
}

#[test]
fn output_is_byte_for_byte_deterministic() {
    let frame = Frame::LonLat {
        lon0: 26.94,
        lat0: 60.47,
    };
    let a = encode_pvs(&strip(30, 200, frame.clone())).unwrap().0;
    let b = encode_pvs(&strip(30, 200, frame)).unwrap().0;
    assert_eq!(a, b);
}

#[test]
fn stats_compare_codings_honestly() {
    let data = strip(
        50,
        300,
        Frame::LonLat {
            lon0: 1.0,
            lat0: 2.0,
        },
    );
    let (bytes, stats) = encode_pvs(&data).unwrap();
    assert_eq!(stats.file_bytes, bytes.len() as u64);
    assert_eq!(stats.raw_bitset_bytes, 100 * 300u64.div_ceil(8));
    // Each record is the shortest coding plus a tag byte, so never worse than raw + 1.
    assert!(stats.record_bytes <= stats.raw_bitset_bytes + 100);
    assert!(stats.record_bytes < stats.raw_bitset_bytes);
    assert!(stats.record_bytes < stats.rle_bitset_bytes);
}

#[test]
fn atomic_write_into_a_missing_folder_fails_and_leaves_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("missing").join("out.pvs");
    let data = strip(
        2,
        5,
        Frame::LonLat {
            lon0: 0.0,
            lat0: 0.0,
        },
    );
    let err = write_pvs(&path, &data).unwrap_err();
    assert!(err.message().contains("out.pvs"), "{err}");
    assert!(!path.exists());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn invalid_data_is_refused_and_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.pvs");
    let mut data = strip(
        2,
        5,
        Frame::LonLat {
            lon0: 0.0,
            lat0: 0.0,
        },
    );
    data.visible[0] = vec![3, 2];
    assert!(write_pvs(&path, &data).is_err());
    data.visible[0] = vec![5];
    assert!(
        write_pvs(&path, &data)
            .unwrap_err()
            .message()
            .contains("only 5 objects")
    );
    data.visible.pop();
    assert!(write_pvs(&path, &data).is_err());
    assert!(!path.exists());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn cell_at_finds_the_containing_triangle() {
    let data = strip(
        10,
        4,
        Frame::LonLat {
            lon0: 0.0,
            lat0: 0.0,
        },
    );
    let reader = PvsReader::from_bytes(encode_pvs(&data).unwrap().0).unwrap();
    // Square k is [10k, 10k+10] x [0, 10]; triangle 2k below the diagonal, 2k+1 above.
    for k in 0..10 {
        let x = k as f64 * 10.0;
        assert_eq!(reader.cell_at(DVec2::new(x + 7.0, 2.0)), Some(2 * k));
        assert_eq!(reader.cell_at(DVec2::new(x + 2.0, 7.0)), Some(2 * k + 1));
        // On the diagonal: either neighbour.
        let on_edge = reader.cell_at(DVec2::new(x + 5.0, 5.0)).unwrap();
        assert!(on_edge == 2 * k || on_edge == 2 * k + 1);
    }
    // Corners and outer edges belong to some cell; outside belongs to none.
    assert!(reader.cell_at(DVec2::new(0.0, 0.0)).is_some());
    assert!(reader.cell_at(DVec2::new(100.0, 10.0)).is_some());
    assert_eq!(reader.cell_at(DVec2::new(-0.003, 5.0)), None);
    assert_eq!(reader.cell_at(DVec2::new(50.0, 10.003)), None);
    // Within the snap distance (2.8 mm) of a cell: the nearest cell.
    assert_eq!(reader.cell_at(DVec2::new(-0.002, 5.0)), Some(1));
    assert_eq!(reader.cell_at(DVec2::new(55.0, 10.002)), Some(11));
    assert_eq!(reader.cell_at(DVec2::new(100.002, 2.0)), Some(18));
    assert_eq!(reader.cell_at(DVec2::new(f64::NAN, 5.0)), None);
}

#[test]
fn cell_at_agrees_with_brute_force_on_random_points() {
    // A fan of irregular triangles around a centre, leaving gaps between them.
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut cells = Vec::new();
    for k in 0..200 {
        let a0 = k as f64 * std::f64::consts::TAU / 200.0;
        let a1 = a0 + 0.025 + rng.random_range(0.0..0.006);
        let r = rng.random_range(50.0..500.0);
        let on_grid = |p: DVec2| citypvs::pvs::mesh::snap(p).unwrap();
        cells.push([
            on_grid(DVec2::new(
                rng.random_range(-3.0..3.0),
                rng.random_range(-3.0..3.0),
            )),
            on_grid(DVec2::new(r * a0.cos(), r * a0.sin())),
            on_grid(DVec2::new(r * a1.cos(), r * a1.sin())),
        ]);
    }
    let n = cells.len();
    let data = PvsData {
        object_prints: Vec::new(),
        info: info(Frame::LonLat {
            lon0: 0.0,
            lat0: 0.0,
        }),
        object_ids: vec!["a".into()],
        cells: cells.clone(),
        visible: vec![vec![0]; n],
    };
    let reader = PvsReader::from_bytes(encode_pvs(&data).unwrap().0).unwrap();
    let contains = |t: &[DVec2; 3], p: DVec2| {
        let s = (t[1] - t[0]).perp_dot(t[2] - t[0]).signum();
        (0..3).all(|k| (t[(k + 1) % 3] - t[k]).perp_dot(p - t[k]) * s >= 0.0)
    };
    let (mut inside, mut near) = (0, 0);
    for _ in 0..20_000 {
        let p = DVec2::new(
            rng.random_range(-520.0..520.0),
            rng.random_range(-520.0..520.0),
        );
        let expected: Vec<usize> = (0..n).filter(|&c| contains(&cells[c], p)).collect();
        // In no cell: the nearest within the snap distance, if any.
        let nearest = (0..n)
            .map(|c| (citypvs::pvs::distance_to_triangle(&cells[c], p), c))
            .filter(|&(d, _)| d <= citypvs::pvs::mesh::SNAP_DISTANCE)
            .min_by(|a, b| a.partial_cmp(b).unwrap());
        match reader.cell_at(p) {
            Some(c) if expected.is_empty() => {
                assert_eq!(Some(c), nearest.map(|(_, c)| c), "{p}");
                near += 1;
            }
            Some(c) => {
                assert!(
                    expected.contains(&c),
                    "{p} -> {c}, expected one of {expected:?}"
                );
                inside += 1;
            }
            None => assert!(
                expected.is_empty() && nearest.is_none(),
                "{p} missed {expected:?}"
            ),
        }
    }
    // Points just outside the cells, near their edges.
    for c in 0..n {
        let t = &cells[c];
        let mid = (t[1] + t[2]) / 2.0;
        let out = (mid - t[0]).normalize();
        for (d, found) in [(0.002, true), (0.004, false)] {
            let p = mid + out * d;
            if (0..n).any(|k| citypvs::pvs::distance_to_triangle(&cells[k], p) <= 0.0028) != found {
                continue;
            }
            assert_eq!(
                reader.cell_at(p).is_some(),
                found,
                "{p} at {d} m from cell {c}"
            );
            near += usize::from(found);
        }
    }
    assert!(inside > 1000, "too few points inside: {inside}");
    assert!(near > 100, "too few points near: {near}");
}

fn sample_file() -> Vec<u8> {
    encode_pvs(&strip(
        40,
        120,
        Frame::Metric {
            origin: DVec2::new(100.0, 200.0),
            crs: Some("EPSG:3067".into()),
        },
    ))
    .unwrap()
    .0
}

#[test]
fn truncation_anywhere_is_a_clear_error() {
    let bytes = sample_file();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cut.pvs");
    for len in (0..bytes.len()).step_by(97) {
        std::fs::write(&path, &bytes[..len]).unwrap();
        let err = crate::common::error_of(PvsReader::open(&path), ErrorKind::Format);
        assert!(err.starts_with(&path.display().to_string()), "{err}");
        if len >= 24 {
            assert!(err.contains("truncated"), "at {len}: {err}");
        }
    }
}

#[test]
fn random_byte_flips_are_detected() {
    let bytes = sample_file();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for _ in 0..500 {
        let mut bad = bytes.clone();
        let at = rng.random_range(0..bad.len());
        bad[at] ^= rng.random_range(1..=255u8);
        let m = crate::common::error_of(PvsReader::from_bytes(bad), ErrorKind::Format);
        assert!(
            m.contains("checksum")
                || m.contains("magic")
                || m.contains("version")
                || m.contains("truncated"),
            "flip at {at}: {m}"
        );
    }
}

#[test]
fn bad_magic_and_version_are_named() {
    let mut bytes = sample_file();
    bytes[0] = b'X';
    assert!(
        crate::common::error_of(PvsReader::from_bytes(bytes), ErrorKind::Format)
            .contains("not a citypvs")
    );
    let mut bytes = sample_file();
    bytes[8] = 4;
    assert!(
        crate::common::error_of(PvsReader::from_bytes(bytes), ErrorKind::Format)
            .contains("reads version 3")
    );
    for old in [1u8, 2] {
        let mut bytes = sample_file();
        bytes[8] = old;
        assert!(
            crate::common::error_of(PvsReader::from_bytes(bytes), ErrorKind::Format)
                .contains(&format!("version {old} file: rebake with this citypvs"))
        );
    }
}

/// Corrupt the body and then repair the length and checksum, so the structural
/// checks behind the checksum are exercised: they must error, never panic.
#[test]
fn structurally_corrupt_files_with_valid_checksums_never_panic() {
    use sha2::{Digest, Sha256};
    let bytes = sample_file();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut errors = 0;
    for _ in 0..3000 {
        let mut bad = bytes[..bytes.len() - 32].to_vec();
        for _ in 0..rng.random_range(1..4) {
            let at = rng.random_range(12..bad.len());
            bad[at] = rng.random();
        }
        if rng.random_bool(0.2) {
            let cut = rng.random_range(24..bad.len());
            bad.truncate(cut);
        }
        let len = (bad.len() + 32) as u64;
        bad[16..24].copy_from_slice(&len.to_le_bytes());
        let digest = Sha256::digest(&bad);
        bad.extend_from_slice(&digest);
        match PvsReader::from_bytes(bad) {
            Err(_) => errors += 1,
            Ok(r) => {
                for c in 0..r.cell_count() {
                    if let Ok(set) = r.visible(c) {
                        assert!(set.iter().all(|&i| (i as usize) < r.object_ids().len()));
                    }
                    let _ = r.cell_at(r.cell_triangle(c)[0]);
                }
            }
        }
    }
    assert!(errors > 100, "only {errors} corruptions detected");
}

/// Blocks are independent: a bad block (checksum repaired) fails only its own cells.
#[test]
fn a_bad_block_fails_only_its_own_cells() {
    use sha2::{Digest, Sha256};
    // 1,200 cells: three blocks of at most 512.
    let data = strip(
        600,
        50,
        Frame::LonLat {
            lon0: 0.0,
            lat0: 0.0,
        },
    );
    let bytes = encode_pvs(&data).unwrap().0;
    let u64_at = |at: usize| u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap()) as usize;
    let u32_at = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
    let block_cells = u32_at(180);
    let lengths: Vec<usize> = (0..6).map(|k| u64_at(184 + 8 * k)).collect();
    let index = 232 + lengths[..4].iter().sum::<usize>();
    let blocks = index + lengths[4];
    let block = 1;
    let start = blocks + u64_at(index + 8 * block);
    let mut bad = bytes[..bytes.len() - 32].to_vec();
    // A block's range-coded stream must start with a zero byte.
    bad[start] = 0xff;
    let digest = Sha256::digest(&bad);
    bad.extend_from_slice(&digest);
    let reader = PvsReader::from_bytes(bad).unwrap();
    let first = block * block_cells;
    let err = reader.visible(first + 3).unwrap_err();
    assert!(
        err.message().contains(&format!("cell {first}")) && err.message().contains("zero byte"),
        "{err}"
    );
    for c in (0..reader.cell_count()).filter(|&c| c / block_cells != block) {
        assert_eq!(reader.visible(c).unwrap(), data.visible[c]);
    }
    assert!(reader.visible(reader.cell_count()).is_err());
}

#[test]
fn ids_sharing_long_prefixes_and_non_ascii_ids_round_trip() {
    let mut data = strip(
        30,
        0,
        Frame::LonLat {
            lon0: 0.0,
            lat0: 0.0,
        },
    );
    let long = "urn:example:city:district-7:block-3:".repeat(6);
    let mut ids: Vec<String> = (0..40).map(|i| format!("{long}{:05}", i * 7)).collect();
    ids.extend(["é", "éa", "ée", "日本", "日本語", "x"].map(String::from));
    let n = ids.len() as u32;
    data.object_ids = ids.clone();
    data.visible = (0..data.cells.len())
        .map(|c| {
            (0..n)
                .filter(|i| (i + c as u32).is_multiple_of(3))
                .collect()
        })
        .collect();
    let (bytes, stats) = encode_pvs(&data).unwrap();
    let reader = PvsReader::from_bytes(bytes).unwrap();
    assert_eq!(reader.object_ids(), ids.as_slice());
    // Shared prefixes are not stored again (an id is at most 16 times its entry).
    let plain: usize = ids.iter().map(|s| 1 + s.len()).sum();
    assert!(
        (stats.object_bytes as usize) < plain / 3,
        "{} of {plain}",
        stats.object_bytes
    );
    for c in 0..data.cells.len() {
        assert_eq!(reader.visible(c).unwrap(), data.visible[c]);
    }
}
