//! The fill-reducing ordering of the Cholesky's unknowns: faer's AMD, or METIS's nested
//! dissection renumbered in a postorder of its elimination tree, chosen by size.

use super::NotFactorizable;
use faer::sparse::SymbolicSparseColMat;
use faer::Index;
use serde::{Deserialize, Serialize};

/// The fill-reducing ordering of the Cholesky's unknowns.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum FillOrdering {
    /// AMD below [`METIS_UNKNOWNS`] unknowns, METIS from there.
    #[default]
    Auto,
    /// faer's approximate minimum degree.
    Amd,
    /// METIS's multilevel nested dissection of the unknowns' graph.
    Metis,
}

/// Unknowns from which [`FillOrdering::Auto`] takes METIS. Measured on one thread on crystals
/// (docs/performance.md, "The crystal against a prepared sample, and the ordering"): in
/// METIS's order an increment takes 7% less at 98,588 unknowns, 6% less at 300,152 and at
/// 3 million (the factorisation 12%, 12% and 22% less), though its analysis takes two to
/// three times AMD's; at 30,000 unknowns (10,000 grains) the factorisation gains 0 to 6% and
/// the analysis, made at every new pattern, takes twice AMD's: AMD is kept there.
pub const METIS_UNKNOWNS: usize = 90_000;

/// METIS's nested dissection of the graph of `pattern` (both triangles stored), with its
/// default options (a fixed seed: the same order every run): the unknown of each pivot, and
/// the pivot of each unknown.
pub(super) fn nested_dissection<I: Index>(
    pattern: &SymbolicSparseColMat<I>,
) -> Result<(Vec<usize>, Vec<usize>), NotFactorizable> {
    let n = pattern.nrows();
    if pattern.row_idx().len() > metis_sys::idx_t::MAX as usize {
        return Err(NotFactorizable(
            "the pattern has more entries than METIS's 32-bit indices hold".into(),
        ));
    }
    let mut xadj: Vec<metis_sys::idx_t> = Vec::with_capacity(n + 1);
    let mut adjncy: Vec<metis_sys::idx_t> = Vec::with_capacity(pattern.row_idx().len());
    xadj.push(0);
    for j in 0..n {
        adjncy.extend(
            pattern
                .row_idx_of_col(j)
                .filter(|&i| i != j)
                .map(|i| i as metis_sys::idx_t),
        );
        xadj.push(adjncy.len() as metis_sys::idx_t);
    }
    let mut options = [0; metis_sys::METIS_NOPTIONS as usize];
    let mut nvtxs = n as metis_sys::idx_t;
    let (mut perm, mut iperm) = (vec![0; n], vec![0; n]);
    // METIS draws from the C library's one random sequence, which it seeds at each call: two
    // calls at once on two threads would draw from each other's, and their orders would
    // depend on the timing.
    static METIS: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _alone = METIS.lock().unwrap_or_else(|e| e.into_inner());
    // SAFETY: xadj and adjncy are a valid graph of n vertices (a symmetric pattern without
    // its diagonal); options, perm and iperm have the sizes METIS writes.
    let status = unsafe {
        metis_sys::METIS_SetDefaultOptions(options.as_mut_ptr());
        metis_sys::METIS_NodeND(
            &mut nvtxs,
            xadj.as_mut_ptr(),
            adjncy.as_mut_ptr(),
            std::ptr::null_mut(),
            options.as_mut_ptr(),
            perm.as_mut_ptr(),
            iperm.as_mut_ptr(),
        )
    };
    match status {
        metis_sys::rstatus_et_METIS_OK => {}
        metis_sys::rstatus_et_METIS_ERROR_MEMORY => {
            return Err(NotFactorizable("METIS ran out of memory".into()))
        }
        status => return Err(NotFactorizable(format!("METIS_NodeND failed ({status})"))),
    }
    let fwd: Vec<usize> = perm.iter().map(|&k| k as usize).collect();
    let inv: Vec<usize> = iperm.iter().map(|&k| k as usize).collect();
    Ok(postordered(pattern, &fwd, &inv))
}

/// The order `fwd` (the unknown of each pivot; `inv` its inverse) renumbered in a postorder
/// of its elimination tree, which gives the same factor: each subtree's pivots then come
/// together, so that chains of columns with the same pattern make the supernodes. AMD's
/// order comes postordered; METIS's leaves do not.
fn postordered<I: Index>(
    pattern: &SymbolicSparseColMat<I>,
    fwd: &[usize],
    inv: &[usize],
) -> (Vec<usize>, Vec<usize>) {
    const NONE: usize = usize::MAX;
    let n = fwd.len();
    // The elimination tree of the ordered matrix (Liu's algorithm, ancestors compressed).
    let (mut parent, mut ancestor) = (vec![NONE; n], vec![NONE; n]);
    for (k, &j) in fwd.iter().enumerate() {
        for i in pattern.row_idx_of_col(j).map(|i| inv[i]).filter(|&i| i < k) {
            let mut r = i;
            while ancestor[r] != NONE && ancestor[r] != k {
                let next = ancestor[r];
                ancestor[r] = k;
                r = next;
            }
            if ancestor[r] == NONE {
                ancestor[r] = k;
                parent[r] = k;
            }
        }
    }
    // Children in increasing order, then a depth-first postorder from the roots.
    let (mut first_child, mut next_sibling) = (vec![NONE; n], vec![NONE; n]);
    for k in (0..n).rev() {
        if parent[k] != NONE {
            next_sibling[k] = first_child[parent[k]];
            first_child[parent[k]] = k;
        }
    }
    let mut post = Vec::with_capacity(n);
    let mut stack = Vec::new();
    for root in (0..n).filter(|&k| parent[k] == NONE) {
        stack.push(root);
        while let Some(&top) = stack.last() {
            let child = first_child[top];
            if child == NONE {
                post.push(top);
                stack.pop();
            } else {
                first_child[top] = next_sibling[child];
                stack.push(child);
            }
        }
    }
    let fwd: Vec<usize> = post.iter().map(|&k| fwd[k]).collect();
    let mut inv = vec![0; n];
    for (k, &j) in fwd.iter().enumerate() {
        inv[j] = k;
    }
    (fwd, inv)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::linear::tests::shifted_laplacian;

    #[test]
    fn metis_order_is_a_postorder_of_its_elimination_tree() {
        let (matrix, _) = shifted_laplacian(40, 0.0);
        let pattern = matrix.symbolic().to_owned().unwrap();
        let (fwd, inv) = nested_dissection(&pattern).unwrap();
        let n = fwd.len();
        assert!((0..n).all(|j| fwd[inv[j]] == j), "a permutation");
        assert_eq!(
            nested_dissection(&pattern).unwrap(),
            (fwd.clone(), inv.clone())
        );
        // In a postorder each pivot's parent (its first later neighbour in the factor) comes
        // later, and each subtree is a run of pivots ending at its root: a pivot's
        // descendants are the pivots just before it.
        let mut parent = vec![usize::MAX; n];
        let mut ancestor: Vec<usize> = (0..n).collect();
        let root = |ancestor: &mut Vec<usize>, mut r: usize| {
            while ancestor[r] != r {
                r = ancestor[r];
            }
            r
        };
        for (k, &j) in fwd.iter().enumerate() {
            for i in pattern.row_idx_of_col(j).map(|i| inv[i]).filter(|&i| i < k) {
                let r = root(&mut ancestor, i);
                if r != k {
                    parent[r] = k;
                    ancestor[r] = k;
                }
            }
        }
        let mut first_descendant: Vec<usize> = (0..n).collect();
        for k in 0..n {
            if parent[k] != usize::MAX {
                assert!(parent[k] > k);
                first_descendant[parent[k]] = first_descendant[parent[k]].min(first_descendant[k]);
            }
        }
        let mut size = vec![1usize; n];
        for k in 0..n {
            if parent[k] != usize::MAX {
                size[parent[k]] += size[k];
            }
        }
        assert!((0..n).all(|k| first_descendant[k] + size[k] == k + 1));
    }
}
