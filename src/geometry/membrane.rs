//! Membranes: flexible boundaries that carry a pressure onto the outermost grains and follow
//! them as they move (the rubber membranes of the unconfined biaxial test, the outer boundary
//! of the cylinder test). A membrane is the chain of outermost grains, found anew at the start
//! of every increment; its pressure acts on the polyline through their centres, each segment
//! `e` carrying `p D |e|` along its inward normal, half to each end. The load enters the
//! global equations directly (no servo), with its tangent.

use super::GrainSet;

/// Which boundary a membrane covers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MembraneShape {
    /// The side of the sample facing `outward` (a unit vector), from one end of the sample to
    /// the other along the side; end pieces reach the sample's extent, so the whole side
    /// carries `p * extent * D`.
    Side {
        /// Unit vector pointing out of the sample through this side.
        outward: [f64; 2],
    },
    /// All around the sample, about `center` (the outer boundary of an annulus).
    Ring {
        /// Centre the chain goes around.
        center: [f64; 2],
    },
}

/// A membrane and its current chain.
#[derive(Debug, Clone, PartialEq)]
pub struct Membrane {
    /// Name used by the load program.
    pub name: String,
    /// Which boundary.
    pub shape: MembraneShape,
    /// Pressure (Pa), compression positive.
    pub pressure: f64,
}

/// The chain of a membrane: grains in order with the sample on the left, and whether it
/// closes on itself.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Chain {
    /// Grains along the membrane.
    pub grains: Vec<usize>,
    /// Whether the last grain links back to the first.
    pub closed: bool,
    /// For a side: the direction along it (sample on the left) and the sample's extent along
    /// it, `[lo, hi]` (m). The end pieces from `lo` to the first grain and from the last grain
    /// to `hi` load the end grains, so the side carries `p (hi - lo) D` in all.
    pub along: [f64; 2],
    /// See `along`.
    pub extent: [f64; 2],
}

impl Chain {
    /// Consecutive grain pairs of the chain.
    pub fn links(&self) -> Vec<(usize, usize)> {
        let g = &self.grains;
        let mut links: Vec<(usize, usize)> = g.windows(2).map(|w| (w[0], w[1])).collect();
        if self.closed && g.len() > 2 {
            links.push((g[g.len() - 1], g[0]));
        }
        links
    }
}

impl Membrane {
    /// The outermost grains, in bands one mean diameter wide along the side (or sectors of one
    /// mean diameter around the ring): in each band the grain reaching furthest out.
    pub fn chain(&self, grains: &GrainSet) -> Chain {
        let band = 2.0 * grains.mean_radius();
        match self.shape {
            MembraneShape::Side { outward } => {
                // Along the side: the outward normal turned 90 degrees anticlockwise keeps the
                // sample on the left.
                let along = [-outward[1], outward[0]];
                let proj = |p: [f64; 2], v: [f64; 2]| p[0] * v[0] + p[1] * v[1];
                let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
                for (p, r) in grains.position.iter().zip(&grains.radius) {
                    lo = lo.min(proj(*p, along) - r);
                    hi = hi.max(proj(*p, along) + r);
                }
                let bands = (((hi - lo) / band).ceil() as usize).max(1);
                let mut best: Vec<Option<(f64, usize)>> = vec![None; bands];
                for (i, (p, r)) in grains.position.iter().zip(&grains.radius).enumerate() {
                    let k = (((proj(*p, along) - lo) / band) as usize).min(bands - 1);
                    let reach = proj(*p, outward) + r;
                    if best[k].is_none_or(|(b, _)| reach > b) {
                        best[k] = Some((reach, i));
                    }
                }
                let mut chain: Vec<usize> = best.into_iter().flatten().map(|(_, i)| i).collect();
                chain.dedup();
                Chain {
                    grains: chain,
                    closed: false,
                    along,
                    extent: [lo, hi],
                }
            }
            MembraneShape::Ring { center } => {
                let outer = grains
                    .position
                    .iter()
                    .zip(&grains.radius)
                    .map(|(p, r)| (p[0] - center[0]).hypot(p[1] - center[1]) + r)
                    .fold(0.0, f64::max);
                let sectors = ((2.0 * std::f64::consts::PI * outer / band).ceil() as usize).max(3);
                let mut best: Vec<Option<(f64, usize)>> = vec![None; sectors];
                for (i, (p, r)) in grains.position.iter().zip(&grains.radius).enumerate() {
                    let d = [p[0] - center[0], p[1] - center[1]];
                    let angle = d[1].atan2(d[0]) + std::f64::consts::PI;
                    let k = ((angle / (2.0 * std::f64::consts::PI) * sectors as f64) as usize)
                        .min(sectors - 1);
                    let reach = d[0].hypot(d[1]) + r;
                    if best[k].is_none_or(|(b, _)| reach > b) {
                        best[k] = Some((reach, i));
                    }
                }
                let mut chain: Vec<usize> = best.into_iter().flatten().map(|(_, i)| i).collect();
                chain.dedup();
                if chain.len() > 1 && chain.first() == chain.last() {
                    chain.pop();
                }
                Chain {
                    grains: chain,
                    closed: true,
                    along: [0.0; 2],
                    extent: [0.0; 2],
                }
            }
        }
    }
}

/// The force of one membrane segment from `a` to `b` on each of its ends, with the sample on
/// the left: `p D / 2` times the segment turned 90 degrees anticlockwise.
pub fn segment_force(a: [f64; 2], b: [f64; 2], pressure_depth: f64) -> [f64; 2] {
    let e = [b[0] - a[0], b[1] - a[1]];
    [-0.5 * pressure_depth * e[1], 0.5 * pressure_depth * e[0]]
}
