//! Work shared over rayon's threads (`--threads`) so that results do not depend on how many
//! there are: each item is computed on its own, results come back in the items' order, and
//! whatever is summed is summed by one thread in a fixed order.
//!
//! Handing work to the pool costs some microseconds, more than a few hundred contacts take
//! to compute: below [`MIN_ITEMS`] items the work stays on the calling thread.

use rayon::prelude::*;

/// Items below which work stays on the calling thread.
pub const MIN_ITEMS: usize = 1024;

/// Fewest items one task takes, so that tasks are not smaller than their cost to hand out.
const CHUNK: usize = 256;

/// Whether `items` items are worth sharing over the threads.
pub fn worth_it(items: usize) -> bool {
    items >= MIN_ITEMS && rayon::current_num_threads() > 1
}

/// `f(&mut item)` for every item, its results into `out` in the items' order.
pub fn map_mut_into<T: Send, U: Send>(
    items: &mut [T],
    out: &mut Vec<U>,
    f: impl Fn(&mut T) -> U + Sync + Send,
) {
    if worth_it(items.len()) {
        items
            .par_iter_mut()
            .with_min_len(CHUNK)
            .map(f)
            .collect_into_vec(out);
    } else {
        out.clear();
        out.extend(items.iter_mut().map(f));
    }
}

/// The items `f(i)` yields for `i` in `0..n`, one after another in the order of `i`.
pub fn flat_map<U: Send, I: IntoIterator<Item = U>>(
    n: usize,
    f: impl Fn(usize) -> I + Sync + Send,
) -> Vec<U> {
    if worth_it(n) {
        (0..n)
            .into_par_iter()
            .with_min_len(CHUNK)
            .flat_map_iter(f)
            .collect()
    } else {
        (0..n).flat_map(f).collect()
    }
}

/// `f(&mut item)` for every item.
pub fn for_each_mut<T: Send>(items: &mut [T], f: impl Fn(&mut T) + Sync + Send) {
    if worth_it(items.len()) {
        items.par_iter_mut().with_min_len(CHUNK).for_each(f);
    } else {
        items.iter_mut().for_each(f);
    }
}

/// Boundaries `0 = b_0 < ... < b_k = len` splitting `0..len` into one part per thread,
/// cut where `weight_before(b)` (non-decreasing, the work before `b`) is shared evenly.
pub fn split(len: usize, weight_before: impl Fn(usize) -> usize) -> Vec<usize> {
    let parts = if worth_it(len) {
        rayon::current_num_threads().min(len)
    } else {
        1
    };
    let total = weight_before(len);
    let mut bounds = vec![0];
    for k in 1..parts {
        let goal = total * k / parts;
        let last = *bounds.last().expect("bounds start at 0");
        // The first boundary whose weight before it reaches the goal (a binary search).
        let (mut lo, mut hi) = (last, len);
        while lo < hi {
            let mid = (lo + hi) / 2;
            if weight_before(mid) < goal {
                lo = mid + 1;
            } else {
                hi = mid;
            }
        }
        if lo > last && lo < len {
            bounds.push(lo);
        }
    }
    bounds.push(len);
    bounds
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_split_shares_the_weight_and_covers_everything() {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .build()
            .unwrap();
        let bounds = pool.install(|| split(10_000, |b| 2 * b));
        assert_eq!(bounds, vec![0, 2500, 5000, 7500, 10_000]);
        let bounds = pool.install(|| split(100, |b| b));
        assert_eq!(bounds, vec![0, 100]);
    }

    #[test]
    fn results_come_back_in_order() {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let mut items: Vec<usize> = (0..5000).collect();
        let mut out = Vec::new();
        pool.install(|| map_mut_into(&mut items, &mut out, |x| 2 * *x));
        assert!(out.iter().enumerate().all(|(i, &y)| y == 2 * i));
        let flat = pool.install(|| flat_map(5000, |i| [i; 2]));
        assert!(flat.chunks(2).enumerate().all(|(i, c)| c == [i, i]));
    }
}
