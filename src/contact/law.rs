//! Contact laws (thesis 2.1): the force of one contact from its overlap and its shear
//! displacement in this increment, by the return map from the last converged state, with
//! its tangent. Each law is trial -> elastic exit -> return map.

/// The fixed properties of one contact, set when it is made.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactParams {
    /// `k_n` (N/m) for the linear law, `M` (N/m^1.5) for Hertz.
    pub stiffness: f64,
    /// `kappa = k_s / k_n`.
    pub kappa: f64,
    /// Coulomb friction `f` (`INFINITY`: no slip).
    pub friction: f64,
    /// Bond strength `F_t` (N) while the bond is intact.
    pub strength: f64,
}

/// What a law returns: the forces and their derivatives.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Response {
    /// Normal force `F_n` (compression positive) (N).
    pub normal_force: f64,
    /// Shear force `F_s` (N).
    pub shear_force: f64,
    /// Whether the return map put the contact on the Coulomb limit.
    pub sliding: bool,
    /// `dF_n / d overlap`.
    pub dfn_dn: f64,
    /// `dF_s / d overlap`.
    pub dfs_dn: f64,
    /// `dF_s / d shear displacement`.
    pub dfs_ds: f64,
}

impl Response {
    /// Whether it has neither force nor stiffness (a contact apart): its block is zero.
    pub fn is_zero(&self) -> bool {
        self.normal_force == 0.0
            && self.shear_force == 0.0
            && self.dfn_dn == 0.0
            && self.dfs_dn == 0.0
            && self.dfs_ds == 0.0
    }
}

/// A contact law: the force by the return map from the committed shear force, and its tangent.
pub trait ContactLaw: Send + Sync {
    /// Normal force and `dF_n/dn` at overlap `n` (negative: apart).
    fn normal(&self, p: &ContactParams, n: f64, bonded: bool) -> (f64, f64);

    /// Shear stiffness `k_s` and `dk_s/dn` at overlap `n`.
    fn shear_stiffness(&self, p: &ContactParams, n: f64) -> (f64, f64);

    /// Normal energy `integral of F_n dn` from first touch to overlap `n`: the potential whose
    /// derivative is [`ContactLaw::normal`] where the contact touches or is bonded (zero
    /// for an unbonded contact apart).
    fn normal_energy(&self, p: &ContactParams, n: f64, bonded: bool) -> f64;

    /// Smallest normal tangent worth offering a solver for a contact expected to carry about
    /// `force_scale`: a law whose stiffness vanishes at first touch says how stiff such a
    /// contact will be; the others need no floor.
    fn tangent_floor(&self, _p: &ContactParams, _force_scale: f64) -> f64 {
        0.0
    }

    /// Whether [`ContactLaw::tangent_floor`] for `force_scale` may exceed the normal tangent
    /// (or secant) of a contact carrying `force`, or its shear stiffness `shear_stiffness`
    /// times `kappa`: where it cannot, it need not be computed. A law that cannot say
    /// cheaply leaves it true.
    fn floor_may_bind(
        &self,
        _p: &ContactParams,
        _force: f64,
        _shear_stiffness: f64,
        _force_scale: f64,
    ) -> bool {
        true
    }

    /// The full response: elastic trial `F_s0 + k_s ds`, then, unless bonded, the return
    /// map onto `|F_s| = f F_n`, with the thesis's elasto-plastic tangent (2.4): `k_s` while
    /// sticking, nothing while sliding, and no shear force change with the overlap.
    fn respond(
        &self,
        p: &ContactParams,
        bonded: bool,
        overlap: f64,
        shear_force0: f64,
        shear_increment: f64,
    ) -> Response {
        let (normal_force, dfn_dn) = self.normal(p, overlap, bonded);
        let ks = self.shear_stiffness(p, overlap).0;
        let trial = shear_force0 + ks * shear_increment;
        let limit = p.friction * normal_force.max(0.0);
        let sticks = bonded || p.friction.is_infinite() || trial.abs() <= limit;
        Response {
            normal_force,
            // Return map: back onto the Coulomb limit, keeping the direction of the trial force.
            shear_force: if sticks {
                trial
            } else {
                trial.signum() * limit
            },
            sliding: !sticks,
            dfn_dn,
            dfs_dn: 0.0,
            dfs_ds: if sticks { ks } else { 0.0 },
        }
    }
}

/// Linear springs with tension while bonded (eqs. 8-12): `F_n = k_n n`, `k_s = kappa k_n`.
/// Within one pass of the relaxation an unbonded contact keeps its spring in tension too, so
/// that the equations stay smooth; the topology update then removes it. The minimisation
/// takes an unbonded contact apart as carrying nothing (see [`ContactLaw::normal_energy`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct LinearCohesive;

impl ContactLaw for LinearCohesive {
    fn normal(&self, p: &ContactParams, n: f64, _bonded: bool) -> (f64, f64) {
        (p.stiffness * n, p.stiffness)
    }

    fn normal_energy(&self, p: &ContactParams, n: f64, bonded: bool) -> f64 {
        if n <= 0.0 && !bonded {
            return 0.0;
        }
        0.5 * p.stiffness * n * n
    }

    fn shear_stiffness(&self, p: &ContactParams, _n: f64) -> (f64, f64) {
        (p.kappa * p.stiffness, 0.0)
    }
}

/// Hertz-Mindlin (eqs. 1-7): `F_n = M n^(3/2)`, secant `k_n = M sqrt(n)`, `k_s = kappa k_n`.
/// `F_n` and its slope vanish together at `n = 0`, so the law is smooth through first touch.
#[derive(Debug, Clone, Copy, Default)]
pub struct HertzMindlin;

impl ContactLaw for HertzMindlin {
    fn normal(&self, p: &ContactParams, n: f64, _bonded: bool) -> (f64, f64) {
        if n <= 0.0 {
            return (0.0, 0.0);
        }
        let root = n.sqrt();
        (p.stiffness * n * root, 1.5 * p.stiffness * root)
    }

    /// `2/5 M n^(5/2)`: C2 at first touch.
    fn normal_energy(&self, p: &ContactParams, n: f64, _bonded: bool) -> f64 {
        if n <= 0.0 {
            return 0.0;
        }
        0.4 * p.stiffness * n * n * n.sqrt()
    }

    fn shear_stiffness(&self, p: &ContactParams, n: f64) -> (f64, f64) {
        if n <= 0.0 {
            return (0.0, 0.0);
        }
        let root = n.sqrt();
        (
            p.kappa * p.stiffness * root,
            0.5 * p.kappa * p.stiffness / root,
        )
    }

    /// The tangent `1.5 M^(2/3) F^(1/3)` of a contact carrying the force scale.
    fn tangent_floor(&self, p: &ContactParams, force_scale: f64) -> f64 {
        1.5 * (p.stiffness * p.stiffness * force_scale).cbrt()
    }

    /// The floor of `F_s = force_scale` exceeds the secant `M sqrt(n)` (two thirds of the
    /// tangent) of a contact carrying `F` only where `F < 3.375 F_s`, and `kappa` times it
    /// exceeds `k_s = kappa M sqrt(n)` only where the force at that overlap, `(k_s /
    /// kappa)^3 / M^2`, is below `3.375 F_s`: tested against `8 F_s`, clear of round-off,
    /// and without the cube root.
    fn floor_may_bind(
        &self,
        p: &ContactParams,
        force: f64,
        shear_stiffness: f64,
        force_scale: f64,
    ) -> bool {
        let km = p.kappa * p.stiffness;
        force < 8.0 * force_scale || shear_stiffness.powi(3) < 8.0 * force_scale * p.kappa * km * km
    }
}

/// Coulomb friction as a potential (method note, step 2): with the shear stiffness `k_s` and
/// the limit `f N` held fixed, the shear force `clamp(F_s0 + k_s s, -f N, f N)` is the
/// derivative of a convex C1 function of the shear displacement `s`, its curvature `k_s`
/// while sticking and 0 while sliding. The return map of the thesis is its value.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Friction {
    /// Shear force `F_s` (N).
    pub force: f64,
    /// `dF_s / ds`: `k_s` sticking, 0 sliding.
    pub stiffness: f64,
    /// The potential `integral of F_s ds` from 0 to `s` (J).
    pub energy: f64,
    /// Whether the force is on the limit.
    pub sliding: bool,
}

/// The friction potential at shear displacement `s` from the committed shear force `force0`,
/// with stiffness `stiffness` and limit `limit` (`INFINITY`: no slip) held.
pub fn friction(force0: f64, stiffness: f64, limit: f64, s: f64) -> Friction {
    // `C(a)`, the integral of clamp(x, -L, L) from 0 to a; the energy is
    // (C(F_s0 + k s) - C(F_s0)) / k, or s clamp(F_s0) without stiffness.
    let clamp = |a: f64| a.clamp(-limit, limit);
    let integral = |a: f64| {
        if a.abs() <= limit {
            0.5 * a * a
        } else {
            limit * a.abs() - 0.5 * limit * limit
        }
    };
    let trial = force0 + stiffness * s;
    // Without a limit (a contact apart) there is nothing to stick with.
    let sliding = trial.abs() > limit || limit <= 0.0;
    let energy = if stiffness > 0.0 {
        (integral(trial) - integral(force0)) / stiffness
    } else {
        s * clamp(force0)
    };
    Friction {
        force: clamp(trial),
        stiffness: if sliding { 0.0 } else { stiffness },
        energy,
        sliding,
    }
}

/// `kappa = 3 (1 - nu) / (2 - nu)` (eq. 6).
pub fn kappa(poisson: f64) -> f64 {
    3.0 * (1.0 - poisson) / (2.0 - poisson)
}

/// Hertz grain stiffness `M = 2 sqrt(2 rbar) G / (3 (1 - nu))` (eq. 1).
pub fn hertz_stiffness(rbar: f64, shear_modulus: f64, poisson: f64) -> f64 {
    2.0 * (2.0 * rbar).sqrt() * shear_modulus / (3.0 * (1.0 - poisson))
}

/// `rbar = 2 r_i r_j / (r_i + r_j)`; against a flat wall (`r_j` infinite) it is `2 r_i`.
pub fn mean_radius(ri: f64, rj: Option<f64>) -> f64 {
    match rj {
        Some(rj) => 2.0 * ri * rj / (ri + rj),
        None => 2.0 * ri,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> ContactParams {
        ContactParams {
            stiffness: 1e8,
            kappa: kappa(0.16),
            friction: 0.5,
            strength: 10.0,
        }
    }

    #[test]
    fn the_hertz_floor_is_skipped_only_where_it_cannot_bind() {
        let p = params();
        let scale = 1e-3;
        let floor = HertzMindlin.tangent_floor(&p, scale);
        let (mut skipped, mut kept) = (0, 0);
        // Overlaps whose forces run from far below the floor's force to far above it, each as
        // the overlap now and as the lag's.
        let overlaps = (0..60).map(|k| 1e-14 * 1.5f64.powi(k));
        for n in overlaps.clone() {
            for n_lag in overlaps.clone() {
                let (force, tangent) = HertzMindlin.normal(&p, n, false);
                let shear = HertzMindlin.shear_stiffness(&p, n_lag).0;
                if HertzMindlin.floor_may_bind(&p, force, shear, scale) {
                    kept += 1;
                } else {
                    skipped += 1;
                    // Neither the secant (two thirds of the tangent) nor the shear stiffness
                    // is below what the floor would give.
                    assert!(floor <= tangent / 1.5, "n {n:e}");
                    assert!(p.kappa * floor <= shear, "n_lag {n_lag:e}");
                }
            }
        }
        // A contact carrying a hundred times the floor's force skips it.
        let n = (100.0 * scale / p.stiffness).powf(2.0 / 3.0);
        let (force, _) = HertzMindlin.normal(&p, n, false);
        let shear = HertzMindlin.shear_stiffness(&p, n).0;
        assert!(!HertzMindlin.floor_may_bind(&p, force, shear, scale));
        assert!(skipped > 0 && kept > 0, "{skipped} skipped, {kept} kept");
    }

    #[test]
    fn return_map_lands_on_the_coulomb_limit() {
        let p = params();
        let r = LinearCohesive.respond(&p, false, 1e-6, 0.0, 1e-5);
        assert!(r.sliding);
        assert!((r.shear_force - 0.5 * 100.0).abs() < 1e-12);
        // The elasto-plastic tangent: no stiffness along the slip.
        assert_eq!((r.dfs_ds, r.dfs_dn), (0.0, 0.0));
    }

    #[test]
    fn friction_force_is_the_derivative_of_its_potential() {
        let h = 1e-9;
        for (f0, k, limit) in [
            (0.3, 2.0, 1.0),
            (-0.8, 5.0, 1.0),
            (1.5, 1.0, 1.0),
            (0.2, 0.0, 0.5),
        ] {
            for s in [-0.7, -0.1, 0.0, 0.05, 0.4, 0.9] {
                let f = friction(f0, k, limit, s);
                let fd = (friction(f0, k, limit, s + h).energy
                    - friction(f0, k, limit, s - h).energy)
                    / (2.0 * h);
                assert!(
                    (fd - f.force).abs() < 1e-6,
                    "f0 {f0} k {k} s {s}: {fd} vs {}",
                    f.force
                );
                assert!(f.force.abs() <= limit);
            }
        }
    }

    #[test]
    fn normal_force_is_the_derivative_of_its_energy() {
        let p = ContactParams {
            stiffness: 3e9,
            ..params()
        };
        let laws: [&dyn ContactLaw; 2] = [&HertzMindlin, &LinearCohesive];
        for law in laws {
            for bonded in [false, true] {
                for n in [-2e-7, 1e-8, 2e-7] {
                    let h = 1e-12;
                    let fd = (law.normal_energy(&p, n + h, bonded)
                        - law.normal_energy(&p, n - h, bonded))
                        / (2.0 * h);
                    let (f, _) = if n > 0.0 || bonded {
                        law.normal(&p, n, bonded)
                    } else {
                        (0.0, 0.0)
                    };
                    assert!((fd - f).abs() <= 1e-6 * f.abs().max(1e-3), "{fd} vs {f}");
                }
            }
        }
    }

    #[test]
    fn hertz_tangent_is_the_derivative() {
        let p = ContactParams {
            stiffness: 3e9,
            ..params()
        };
        let n = 2e-7;
        let h = 1e-13;
        let (f0, df) = HertzMindlin.normal(&p, n, false);
        let (f1, _) = HertzMindlin.normal(&p, n + h, false);
        assert!(((f1 - f0) / h - df).abs() < 1e-5 * df);
    }
}
