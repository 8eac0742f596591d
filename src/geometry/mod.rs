//! Grains and walls: where things are, and the neighbour ('friends') lists that say which
//! pairs may touch (thesis appendix 3).

mod chain_watch;
mod friends;
mod grid;
mod membrane;

pub use chain_watch::ChainWatch;
pub use friends::{gap as gap_between, FriendSet, Pair, Side};
pub use grid::CellGrid;
pub use membrane::{chains, Chain, Membrane, MembraneShape};

/// The grains: centres, rotations and radii, one entry per grain (`GrainId` = index).
///
/// A centre is kept as `origin + displacement`: contact geometry is formed from differences
/// of origins plus differences of displacements, so its rounding error scales with the
/// grain size and the displacements, not with the distance from the coordinate origin
/// (which would set a floor on the equilibrium residual of large samples).
#[derive(Debug, Clone, PartialEq)]
pub struct GrainSet {
    /// Centres `x_i = origin + displacement` (m) (kept in step with both).
    pub position: Vec<[f64; 2]>,
    /// Where each grain started (m); never changes.
    pub origin: Vec<[f64; 2]>,
    /// Displacement of each centre since the start (m).
    pub displacement: Vec<[f64; 2]>,
    /// Rotations `phi_i` (rad), anticlockwise.
    pub rotation: Vec<f64>,
    /// Radii `r_i` (m).
    pub radius: Vec<f64>,
    /// Whether each grain has been taken out of the sample (a cluster broken out of it, see
    /// [`crate::simulation::Simulation::take_out`]): it keeps its row and stays where it was
    /// taken out, but touches nothing, carries nothing and is not measured.
    pub taken_out: Vec<bool>,
}

impl GrainSet {
    /// Grains at rest (zero rotation and displacement).
    pub fn new(position: Vec<[f64; 2]>, radius: Vec<f64>) -> Self {
        let n = position.len();
        GrainSet {
            origin: position.clone(),
            position,
            displacement: vec![[0.0; 2]; n],
            rotation: vec![0.0; n],
            radius,
            taken_out: vec![false; n],
        }
    }

    /// Grains at `origin + displacement`.
    pub fn from_parts(
        origin: Vec<[f64; 2]>,
        displacement: Vec<[f64; 2]>,
        rotation: Vec<f64>,
        radius: Vec<f64>,
    ) -> Self {
        let position = origin
            .iter()
            .zip(&displacement)
            .map(|(o, d)| [o[0] + d[0], o[1] + d[1]])
            .collect();
        let n = radius.len();
        GrainSet {
            position,
            origin,
            displacement,
            rotation,
            radius,
            taken_out: vec![false; n],
        }
    }

    /// Move every grain by `step` (one entry per grain).
    pub fn displace(&mut self, step: &[[f64; 2]]) {
        for (((d, s), o), p) in self
            .displacement
            .iter_mut()
            .zip(step)
            .zip(&self.origin)
            .zip(&mut self.position)
        {
            d[0] += s[0];
            d[1] += s[1];
            *p = [o[0] + d[0], o[1] + d[1]];
        }
    }

    /// Vector from the centre of grain `a` to that of `b`, formed from differences only.
    #[inline]
    pub fn branch(&self, a: usize, b: usize) -> [f64; 2] {
        let (oa, ob) = (self.origin[a], self.origin[b]);
        let (da, db) = (self.displacement[a], self.displacement[b]);
        [
            (ob[0] - oa[0]) + (db[0] - da[0]),
            (ob[1] - oa[1]) + (db[1] - da[1]),
        ]
    }

    /// Number of grains.
    pub fn len(&self) -> usize {
        self.radius.len()
    }

    /// Whether there are no grains.
    pub fn is_empty(&self) -> bool {
        self.radius.is_empty()
    }

    /// The grains still in the sample (not taken out), in order.
    pub fn in_sample(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.len()).filter(|&g| !self.taken_out[g])
    }

    /// Mean radius (of every grain, those taken out too: it sets the solver's length scale,
    /// which must not change as grains are taken out).
    pub fn mean_radius(&self) -> f64 {
        self.radius.iter().sum::<f64>() / self.len().max(1) as f64
    }

    /// Extent along `direction` of the grains in the sample, centred at `position` (theirs,
    /// or where an iterate has them) (m).
    pub fn extent_along(&self, position: &[[f64; 2]], direction: [f64; 2]) -> f64 {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for g in self.in_sample() {
            let (p, r) = (position[g], self.radius[g]);
            let s = p[0] * direction[0] + p[1] * direction[1];
            lo = lo.min(s - r);
            hi = hi.max(s + r);
        }
        (hi - lo).max(0.0)
    }

    /// Smallest axis-aligned box around all grains: `[xmin, ymin, xmax, ymax]`.
    pub fn bounding_box(&self) -> [f64; 4] {
        let mut b = [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ];
        for (p, r) in self.position.iter().zip(&self.radius) {
            b[0] = b[0].min(p[0] - r);
            b[1] = b[1].min(p[1] - r);
            b[2] = b[2].max(p[0] + r);
            b[3] = b[3].max(p[1] + r);
        }
        b
    }
}

/// How a wall's normal position is governed.
pub use crate::scene::WallControl;

/// The circle of a circular wall: a ring with the grains inside it (an outer confinement) or
/// a plug with the grains outside it (a rigid borehole core, a support, a loading point).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Circle {
    /// Centre (m).
    pub center: [f64; 2],
    /// Radius at the start (m).
    pub radius: f64,
    /// Whether the grains are inside the circle (a ring) or outside it (a plug).
    pub grains_inside: bool,
    /// Unit direction in which a plug's centre moves, its radius fixed (a loading point
    /// pushed into a beam); `None`: the centre stays and the radius changes.
    pub moves: Option<[f64; 2]>,
}

impl Circle {
    /// How the radius changes when the wall moves into the sample: +1 for a plug, -1 for a ring.
    pub fn sign(&self) -> f64 {
        if self.grains_inside {
            -1.0
        } else {
            1.0
        }
    }

    /// The centre after the wall moved `position` into the sample.
    pub fn center_at(&self, position: f64) -> [f64; 2] {
        match self.moves {
            Some(m) => [
                self.center[0] + position * m[0],
                self.center[1] + position * m[1],
            ],
            None => self.center,
        }
    }

    /// The radius after the wall moved `position` into the sample.
    pub fn radius_at(&self, position: f64) -> f64 {
        match self.moves {
            Some(_) => self.radius,
            None => self.radius + self.sign() * position,
        }
    }
}

/// A rigid wall: a straight line with the grains on the side its normal points to, or a
/// circle. A line moves along its starting normal (`position`) and along itself (`slide`),
/// and may turn about its pivot (`turn`): it passes through `pivot + position normal + slide
/// tangent` with the normal turned by `turn`, so unturned it is `normal . x = offset +
/// position`. A circle grows or shrinks, or a plug's centre moves along its `moves`
/// (`position`, into the sample positive).
#[derive(Debug, Clone, PartialEq)]
pub struct Wall {
    /// Name from the scene.
    pub name: String,
    /// Unit normal into the sample at the start (before any turn).
    pub normal: [f64; 2],
    /// `normal . point` of the wall at the start.
    pub offset: f64,
    /// The point of the starting line the wall turns about (m) (it moves with the wall's
    /// `position` and `slide`): a box's side walls turn about their bottom ends.
    pub pivot: [f64; 2],
    /// Angle the line has turned about its pivot since the start (rad, anticlockwise).
    pub turn: f64,
    /// Displacement along the normal since the start (m) (into the sample positive).
    pub position: f64,
    /// Displacement along the wall since the start (m) (along `tangent()`).
    pub slide: f64,
    /// Prescribed, or an unknown loaded by a stress.
    pub control: WallControl,
    /// Applied stress (Pa) (stress-controlled walls).
    pub stress: f64,
    /// Fixed loaded length (m); `None`: the distance between the walls perpendicular to it.
    pub length: Option<f64>,
    /// Grain-wall friction `f_gw` (`INFINITY` when glued).
    pub friction: f64,
    /// The circle of a circular wall (`normal` and `offset` then unused).
    pub circle: Option<Circle>,
}

impl Wall {
    /// The wall's surface constant after moving `position` into the sample: the line constant
    /// `offset + position` along its starting normal, or the circle's current radius.
    pub fn surface(&self, position: f64) -> f64 {
        match &self.circle {
            Some(c) => c.radius_at(position),
            None => self.offset + position,
        }
    }

    /// The constant of the line now along its current normal: `current_normal() . x` on it.
    pub fn line_constant(&self) -> f64 {
        let (start, moved) = self.line_parts();
        start + moved
    }

    /// [`Wall::line_constant`] in two parts: the line where it started and what its normal
    /// move adds (`offset` and `position` until it turns), so that a distance can take the
    /// small move from the small displacement before the large terms meet.
    pub fn line_parts(&self) -> (f64, f64) {
        if self.turn == 0.0 {
            return (self.offset, self.position);
        }
        let (n, t) = (self.current_normal(), self.tangent());
        let at_start = [
            self.pivot[0] + self.slide * t[0],
            self.pivot[1] + self.slide * t[1],
        ];
        (
            n[0] * at_start[0] + n[1] * at_start[1],
            self.position * (n[0] * self.normal[0] + n[1] * self.normal[1]),
        )
    }

    /// The direction along the wall at the start: the normal turned 90 degrees anticlockwise
    /// (the direction of `slide`).
    pub fn tangent(&self) -> [f64; 2] {
        [-self.normal[1], self.normal[0]]
    }

    /// The normal into the sample now: the starting one turned by `turn`.
    pub fn current_normal(&self) -> [f64; 2] {
        rotate(self.normal, self.turn)
    }

    /// The direction along the wall now: the current normal turned 90 degrees anticlockwise.
    pub fn current_tangent(&self) -> [f64; 2] {
        let n = self.current_normal();
        [-n[1], n[0]]
    }

    /// Where the pivot is after the wall moved `position` into the sample (and `slide` along
    /// itself).
    pub fn pivot_at(&self, position: f64) -> [f64; 2] {
        let t = self.tangent();
        [
            self.pivot[0] + position * self.normal[0] + self.slide * t[0],
            self.pivot[1] + position * self.normal[1] + self.slide * t[1],
        ]
    }

    /// Where this straight wall's line meets `other`'s; `None` when they are parallel.
    pub fn corner(&self, other: &Wall) -> Option<[f64; 2]> {
        let (a, b) = (self.current_normal(), other.current_normal());
        let det = a[0] * b[1] - a[1] * b[0];
        if det.abs() < 1e-9 {
            return None;
        }
        let (ca, cb) = (self.line_constant(), other.line_constant());
        Some([(ca * b[1] - cb * a[1]) / det, (a[0] * cb - b[0] * ca) / det])
    }

    /// Signed distance from the wall's surface to a point (positive on the sample side).
    pub fn distance(&self, x: [f64; 2]) -> f64 {
        match &self.circle {
            Some(c) => {
                let surface = self.surface(self.position);
                let center = c.center_at(self.position);
                let from_center = (x[0] - center[0]).hypot(x[1] - center[1]);
                -c.sign() * (surface - from_center)
            }
            None => {
                let n = self.current_normal();
                n[0] * x[0] + n[1] * x[1] - self.line_constant()
            }
        }
    }

    /// The direction in which a unit move of this wall carries its side of a contact whose
    /// normal is `normal`: the centre's direction for a moving plug, the contact normal for a
    /// growing circle (its surface moves out along it), a line's starting normal (a turned
    /// line still moves along it).
    pub fn push_direction(&self, normal: [f64; 2]) -> [f64; 2] {
        match self.circle {
            Some(c) => c.moves.unwrap_or(normal),
            None => self.normal,
        }
    }

    /// Whether two straight walls face each other (opposite normals at the start: walls that
    /// turn keep the box they started as).
    pub fn faces(&self, other: &Wall) -> bool {
        self.circle.is_none()
            && other.circle.is_none()
            && self.normal[0] * other.normal[0] + self.normal[1] * other.normal[1] < -0.999
    }

    /// Whether two straight walls are perpendicular (at the start).
    pub fn perpendicular_to(&self, other: &Wall) -> bool {
        self.circle.is_none()
            && other.circle.is_none()
            && (self.normal[0] * other.normal[0] + self.normal[1] * other.normal[1]).abs() < 1e-3
    }
}

/// The walls, with the area they enclose.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct WallSet {
    /// Every wall, in scene order (`WallId` = index).
    pub walls: Vec<Wall>,
}

impl WallSet {
    /// Number of walls.
    pub fn len(&self) -> usize {
        self.walls.len()
    }

    /// Whether there are no walls.
    pub fn is_empty(&self) -> bool {
        self.walls.is_empty()
    }

    /// The pairs of walls that bound wall `w` on its two ends: walls perpendicular to it that
    /// face each other. The loaded length of `w` is the distance between them.
    pub fn span_walls(&self, w: usize) -> Option<(usize, usize)> {
        let wall = &self.walls[w];
        for (a, wa) in self.walls.iter().enumerate() {
            if !wa.perpendicular_to(wall) {
                continue;
            }
            for (b, wb) in self.walls.iter().enumerate().skip(a + 1) {
                if wb.perpendicular_to(wall) && wa.faces(wb) {
                    return Some((a, b));
                }
            }
        }
        None
    }

    /// The first straight wall facing wall `w`.
    pub fn facing(&self, w: usize) -> Option<usize> {
        self.walls.iter().position(|o| o.faces(&self.walls[w]))
    }

    /// Distance between two facing walls (along their starting normals: the height of a
    /// shear box whose side walls turned).
    pub fn gap(&self, a: usize, b: usize) -> f64 {
        let (wa, wb) = (&self.walls[a], &self.walls[b]);
        // Lines n.x = ca and -n.x = cb: the gap is -(ca + cb).
        -(wa.offset + wa.position + wb.offset + wb.position)
    }

    /// Loaded length of wall `w` with the grains where they are: its fixed length, a circle's
    /// circumference, the gap between its span walls, or (between membranes) the extent of
    /// the grains along it.
    pub fn loaded_length(&self, w: usize, grains: &GrainSet) -> f64 {
        match self.length(w) {
            Some(l) => l,
            None => grains.extent_along(&grains.position, self.walls[w].tangent()),
        }
    }

    /// Loaded length of wall `w` now: its fixed length, a circle's circumference, or the gap
    /// between its span walls (`None` when it has none of these).
    pub fn length(&self, w: usize) -> Option<f64> {
        let wall = &self.walls[w];
        match (wall.length, &wall.circle) {
            (Some(l), _) => Some(l),
            (None, Some(_)) => Some(2.0 * std::f64::consts::PI * wall.surface(wall.position)),
            (None, None) => self.span_walls(w).map(|(a, b)| self.gap(a, b)),
        }
    }

    /// Area enclosed by the walls: inside a ring, or inside the convex polygon of the straight
    /// walls, less the plugs in it.
    pub fn enclosed_area(&self) -> Option<f64> {
        let circle_area = |w: &Wall| std::f64::consts::PI * w.surface(w.position).powi(2);
        let plugs: f64 = self
            .walls
            .iter()
            .filter(|w| w.circle.is_some_and(|c| !c.grains_inside))
            .map(circle_area)
            .sum();
        if let Some(ring) = self
            .walls
            .iter()
            .find(|w| w.circle.is_some_and(|c| c.grains_inside))
        {
            return Some(circle_area(ring) - plugs);
        }
        self.lines_area().map(|a| a - plugs)
    }

    /// Area of the convex polygon that the straight walls close (the intersection of their
    /// half-planes, taken in the order of their normals' angles).
    fn lines_area(&self) -> Option<f64> {
        let lines: Vec<&Wall> = self.walls.iter().filter(|w| w.circle.is_none()).collect();
        if lines.len() < 3 {
            return None;
        }
        let mut order: Vec<usize> = (0..lines.len()).collect();
        let angle = |w: &Wall| {
            let n = w.current_normal();
            n[1].atan2(n[0])
        };
        order.sort_by(|&a, &b| angle(lines[a]).total_cmp(&angle(lines[b])));
        let mut corners = Vec::with_capacity(order.len());
        for k in 0..order.len() {
            corners.push(lines[order[k]].corner(lines[order[(k + 1) % order.len()]])?);
        }
        let area = polygon_area(&corners);
        (area > 0.0).then_some(area)
    }
}

/// Squared lengths within this share of a squared limit are too close to it to be compared
/// without the length itself: the rounding of either is a few parts in 10^16.
const SQUARED_DOUBT: f64 = 1e-12;

/// Whether `v` is longer than `limit` beyond doubt, told from its squared length without a
/// square root; where this says no, the length may still be, and `hypot` decides.
pub fn surely_longer(v: [f64; 2], limit: f64) -> bool {
    v[0] * v[0] + v[1] * v[1] > (1.0 + SQUARED_DOUBT) * limit * limit
}

/// Whether `v` is shorter than `limit` beyond doubt (see [`surely_longer`]).
pub fn surely_shorter(v: [f64; 2], limit: f64) -> bool {
    v[0] * v[0] + v[1] * v[1] < (1.0 - SQUARED_DOUBT) * limit * limit
}

/// `v` turned by `angle` (rad, anticlockwise).
pub fn rotate(v: [f64; 2], angle: f64) -> [f64; 2] {
    let (s, c) = angle.sin_cos();
    [c * v[0] - s * v[1], s * v[0] + c * v[1]]
}

/// Signed area of a polygon (positive when its corners run anticlockwise).
pub fn polygon_area(corners: &[[f64; 2]]) -> f64 {
    let mut twice = 0.0;
    for k in 0..corners.len() {
        let (p, q) = (corners[k], corners[(k + 1) % corners.len()]);
        twice += p[0] * q[1] - q[0] * p[1];
    }
    0.5 * twice
}
