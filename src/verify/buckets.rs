//! Sorting by a floating-point key in about linear time when the keys are
//! spread over a known range: one counting pass into buckets of equal
//! width, then each bucket sorted on its own. The bucket is computed from
//! the key by operations that are each monotone (a difference with a
//! constant, a product with a factor that is not negative, a truncation
//! that saturates), so a lower key never lands in a later bucket, and the
//! buckets, each sorted by `f64::total_cmp`, follow one another in that
//! order. Items of equal keys may come in any order.

/// Working memory of [`sort_in_buckets`], kept between calls.
#[derive(Debug, Default)]
pub struct Buckets<T> {
    sorted: Vec<T>,
    bucket_of: Vec<u32>,
    starts: Vec<u32>,
}

/// Sorts `items` by `key` (every key finite and in `low..=high`) in the
/// order of `f64::total_cmp`, about four items a bucket.
pub fn sort_in_buckets<T: Copy + Default>(
    items: &mut Vec<T>,
    key: impl Fn(&T) -> f64,
    (low, high): (f64, f64),
    memory: &mut Buckets<T>,
) {
    let buckets = (items.len() / 4).max(1);
    let scale = if high > low {
        buckets as f64 / (high - low)
    } else {
        0.0
    };
    let Buckets {
        sorted,
        bucket_of,
        starts,
    } = memory;
    bucket_of.clear();
    bucket_of.extend(
        items
            .iter()
            .map(|item| (((key(item) - low) * scale) as usize).min(buckets - 1) as u32),
    );
    starts.clear();
    starts.resize(buckets + 1, 0);
    for &b in bucket_of.iter() {
        starts[b as usize + 1] += 1;
    }
    for b in 0..buckets {
        starts[b + 1] += starts[b];
    }
    sorted.clear();
    sorted.resize(items.len(), T::default());
    for (&item, &b) in items.iter().zip(bucket_of.iter()) {
        // `starts[b]` serves as the bucket's cursor, then is put back.
        sorted[starts[b as usize] as usize] = item;
        starts[b as usize] += 1;
    }
    // Each cursor now stands at its bucket's end, the next one's start.
    let mut start = 0;
    for &end in &starts[..buckets] {
        let end = end as usize;
        sorted[start..end].sort_unstable_by(|p, q| key(p).total_cmp(&key(q)));
        start = end;
    }
    std::mem::swap(items, sorted);
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::f64::consts::PI;

    /// Keys near the buckets' borders and the ends of the range, and both
    /// zeros, as well as any.
    fn azimuth() -> impl Strategy<Value = f64> {
        prop_oneof![
            -PI..=PI,
            Just(-PI),
            Just(PI),
            Just(0.0),
            Just(-0.0),
            (0u32..64, -3i64..=3).prop_map(|(k, ulps)| {
                let a = -PI + std::f64::consts::TAU * k as f64 / 64.0;
                f64::from_bits((a.to_bits() as i64 + ulps) as u64).clamp(-PI, PI)
            }),
        ]
    }

    fn check(pairs: &[(f64, f64)], range: (f64, f64)) -> Result<(), TestCaseError> {
        let mut bucketed = pairs.to_vec();
        sort_in_buckets(&mut bucketed, |p| p.0, range, &mut Buckets::default());
        let mut compared = pairs.to_vec();
        compared.sort_by(|p, q| p.0.total_cmp(&q.0));
        let keys = |v: &[(f64, f64)]| v.iter().map(|p| p.0.to_bits()).collect::<Vec<_>>();
        prop_assert_eq!(keys(&bucketed), keys(&compared));
        let all = |v: &[(f64, f64)]| {
            let mut b: Vec<(u64, u64)> = v.iter().map(|p| (p.0.to_bits(), p.1.to_bits())).collect();
            b.sort_unstable();
            b
        };
        prop_assert_eq!(all(&bucketed), all(pairs));
        Ok(())
    }

    proptest! {
        /// Azimuths come out in the order of a comparison sort by
        /// `total_cmp`, and every item is kept.
        #[test]
        fn azimuths_come_out_as_a_comparison_sort_orders_them(
            pairs in proptest::collection::vec((azimuth(), 0.0f64..100.0), 0..400),
        ) {
            check(&pairs, (-PI, PI))?;
        }

        /// So do distances, also when they are all equal.
        #[test]
        fn distances_come_out_as_a_comparison_sort_orders_them(
            keys in proptest::collection::vec(prop_oneof![0.0f64..3000.0, Just(0.0), Just(7.5)], 0..400),
            all_equal in any::<bool>(),
        ) {
            let pairs: Vec<(f64, f64)> = keys
                .iter()
                .enumerate()
                .map(|(i, &k)| (if all_equal { 7.5 } else { k }, i as f64))
                .collect();
            let high = pairs.iter().map(|p| p.0).fold(0.0, f64::max);
            check(&pairs, (0.0, high))?;
        }
    }
}
