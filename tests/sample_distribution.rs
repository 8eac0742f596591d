//! Grain size distributions (thesis appendix 4) and sprinkling: drawn radii follow the
//! distribution (mean, bounds, Kolmogorov-Smirnov), the formulas agree with each other, and
//! sprinkled grains never overlap at their scaled size, stay inside, and depend on the seed
//! only.

use grainstat::geometry::GrainSet;
use grainstat::sample::{sprinkle, Region, SampleError, SizeDistribution, SizeKind};
use std::time::Instant;

/// The thesis's average radius, 0.1 mm.
const MEAN: f64 = 1e-4;

/// Radii drawn per distribution.
const N: usize = 20_000;

fn all() -> Vec<SizeDistribution> {
    let mut out = Vec::new();
    for kind in [SizeKind::A, SizeKind::B] {
        for ratio in [4.0, 1.5, 10.0] {
            out.push(SizeDistribution::new(kind, MEAN, ratio).unwrap());
        }
    }
    out
}

/// Kolmogorov-Smirnov statistic `max |F_n - F|` of a sample against a cdf.
fn ks(radii: &[f64], d: &SizeDistribution) -> f64 {
    let mut sorted = radii.to_vec();
    sorted.sort_by(f64::total_cmp);
    let n = sorted.len() as f64;
    sorted
        .iter()
        .enumerate()
        .map(|(i, &r)| {
            let f = d.cdf(r);
            (f - i as f64 / n).abs().max(((i + 1) as f64 / n - f).abs())
        })
        .fold(0.0, f64::max)
}

/// Composite Simpson rule of `f` over `[a, b]` with `n` (even) intervals.
fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let h = (b - a) / n as f64;
    let inner: f64 = (1..n)
        .map(|k| f(a + k as f64 * h) * if k % 2 == 1 { 4.0 } else { 2.0 })
        .sum();
    (f(a) + f(b) + inner) * h / 3.0
}

#[test]
fn drawn_radii_follow_the_distribution() {
    let critical = 1.63 / (N as f64).sqrt();
    // A seed per distribution: with one seed every KS statistic would be the same number,
    // that of the uniforms the radii come from (the quantile is monotonic).
    for (seed, d) in (2024..).zip(all()) {
        let radii = d.radii(N, seed);
        let (lo, hi) = (d.r_min(), d.r_max());
        let mean = radii.iter().sum::<f64>() / N as f64;
        let min = radii.iter().copied().fold(f64::INFINITY, f64::min);
        let max = radii.iter().copied().fold(0.0, f64::max);
        let ks = ks(&radii, &d);
        println!(
            "type {:?} M = {:>4}: r_min {:.4e} r_max {:.4e} | mean {:.5e} ({:+.3}%) | min {:.4e} \
             max {:.4e} | KS D = {:.5} (1% critical {:.5})",
            d.kind,
            d.ratio,
            lo,
            hi,
            mean,
            100.0 * (mean / MEAN - 1.0),
            min,
            max,
            ks,
            critical
        );
        assert!((mean / MEAN - 1.0).abs() < 0.01, "{d:?}: mean {mean}");
        assert!(radii.iter().all(|&r| (lo..=hi).contains(&r)), "{d:?}");
        // Within 10 expected gaps of the bounds: cdf(min) and 1 - cdf(max) below 10 / n.
        assert!(d.cdf(min) < 10.0 / N as f64, "{d:?}: min {min}");
        assert!(1.0 - d.cdf(max) < 10.0 / N as f64, "{d:?}: max {max}");
        assert!(ks < critical, "{d:?}: D = {ks}");
        // The radii really are spread: M is the ratio of the bounds.
        assert!((hi / lo / d.ratio - 1.0).abs() < 1e-14);
        assert!(max / min > 0.95 * d.ratio, "{d:?}");
    }
}

#[test]
fn formulas_agree() {
    for d in all() {
        let (lo, hi) = (d.r_min(), d.r_max());
        assert!((d.cdf(hi) - 1.0).abs() < 1e-14, "{d:?}");
        assert_eq!(d.cdf(lo), 0.0, "{d:?}");
        assert_eq!((d.cdf(0.5 * lo), d.cdf(2.0 * hi)), (0.0, 1.0));
        assert_eq!((d.pdf(0.5 * lo), d.pdf(2.0 * hi)), (0.0, 0.0));

        // The density integrates to 1, its first moment to the analytic mean, and both to
        // the cdf between.
        let total = simpson(|r| d.pdf(r), lo, hi, 20_000);
        let first = simpson(|r| r * d.pdf(r), lo, hi, 20_000);
        let half = simpson(|r| d.pdf(r), lo, d.median(), 20_000);
        println!(
            "type {:?} M = {:>4}: int pdf = {:.12}, int r pdf = {:.10e}, mean() = {:.10e}",
            d.kind,
            d.ratio,
            total,
            first,
            d.mean()
        );
        assert!((total - 1.0).abs() < 1e-10, "{d:?}: {total}");
        assert!((first / d.mean() - 1.0).abs() < 1e-10, "{d:?}: {first}");
        assert!((half - 0.5).abs() < 1e-10, "{d:?}: {half}");
        // The mean of the endpoints is the average radius asked for (A.5, A.8).
        assert!((d.mean() / MEAN - 1.0).abs() < 1e-14, "{d:?}");

        // The quantile inverts the cdf.
        for k in 0..=100 {
            let p = k as f64 / 100.0;
            assert!((d.cdf(d.quantile(p)) - p).abs() < 1e-12, "{d:?} at {p}");
        }
    }
}

#[test]
fn the_formulas_of_the_thesis() {
    for ratio in [4.0, 1.5, 10.0] {
        let m: f64 = ratio;
        let a = SizeDistribution::new(SizeKind::A, MEAN, m).unwrap();
        // A.5: rbar = r_max 3 (M^2 - 1) / (2 (M^3 - 1)).
        let a5 = a.r_max() * 3.0 * (m * m - 1.0) / (2.0 * (m * m * m - 1.0));
        assert!((a5 / MEAN - 1.0).abs() < 1e-14);
        // A.4 as printed, against the quantile.
        let (lo, hi) = (a.r_min(), a.r_max());
        for x in [0.0, 0.1, 0.5, 0.9, 0.999] {
            let a4 = (lo.powi(-3) - (hi.powi(3) - lo.powi(3)) / (hi.powi(3) * lo.powi(3)) * x)
                .powf(-1.0 / 3.0);
            assert!((a.quantile(x) / a4 - 1.0).abs() < 1e-13, "M {m} x {x}");
        }
        // A.8: rbar = r_min (M + 1) / 2.
        let b = SizeDistribution::new(SizeKind::B, MEAN, m).unwrap();
        assert!((b.r_min() * (m + 1.0) / 2.0 / MEAN - 1.0).abs() < 1e-14);

        // A.6. The median of A.3 is r_min (2 M^3 / (M^3 + 1))^(1/3), which the draws
        // confirm; A.6's (M + 1) / (2 sqrt(M)) is not rbar / r_50 for it, nor for the
        // median by weight (sqrt(r_min r_max), where the sieve curve of A.1 is at 50%).
        let r50 = a.median();
        let exact = lo * (2.0 * m.powi(3) / (m.powi(3) + 1.0)).cbrt();
        assert!((r50 / exact - 1.0).abs() < 1e-14);
        let mut radii = a.radii(N, 7);
        radii.sort_by(f64::total_cmp);
        let empirical = 0.5 * (radii[N / 2 - 1] + radii[N / 2]);
        assert!(
            (empirical / r50 - 1.0).abs() < 0.01,
            "M {m}: {empirical} {r50}"
        );
        let a6 = (m + 1.0) / (2.0 * m.sqrt());
        let by_weight = MEAN / (lo * hi).sqrt();
        println!(
            "type A M = {m:>4}: rbar / r50 = {:.4} (by number), {:.4} (by weight); A.6 gives {:.4}",
            MEAN / r50,
            by_weight,
            a6
        );
        if m > 1.5 {
            assert!((MEAN / r50 - a6).abs() > 0.1 && (by_weight - a6).abs() > 0.1);
        }
    }
}

#[test]
fn radii_depend_on_the_seed_only() {
    for d in all() {
        let a = d.radii(1000, 5);
        assert_eq!(a, d.radii(1000, 5));
        assert_ne!(a, d.radii(1000, 6));
        // A prefix of a longer stream.
        assert_eq!(a[..10], d.radii(10, 5)[..]);
    }
    // The stream is pinned: ChaCha8, the 53-bit uniform of rand and basic arithmetic, so
    // these bits are the same on every machine (and a change of any of them shows here).
    let a = SizeDistribution::new(SizeKind::A, MEAN, 4.0).unwrap();
    let b = SizeDistribution::new(SizeKind::B, MEAN, 4.0).unwrap();
    let bits =
        |d: &SizeDistribution| -> Vec<u64> { d.radii(3, 42).iter().map(|r| r.to_bits()).collect() };
    println!("pinned bits: A {:x?} B {:x?}", bits(&a), bits(&b));
    assert_eq!(bits(&a), PINNED_A);
    assert_eq!(bits(&b), PINNED_B);
}

const PINNED_A: [u64; 3] = [0x3f1a966c616a8908, 0x3f26de9da9096444, 0x3f1603a6fba22993];
const PINNED_B: [u64; 3] = [0x3f1fefb540c9091a, 0x3f24307dd0b33fea, 0x3f17ef2bdf53afd8];

#[test]
fn serde_names() {
    let d: SizeDistribution =
        toml::from_str("kind = \"a\"\nmean_radius = 1e-4\nratio = 4.0\n").unwrap();
    assert_eq!(d, SizeDistribution::new(SizeKind::A, 1e-4, 4.0).unwrap());
    assert!(
        toml::from_str::<SizeDistribution>("kind = \"A\"\nmean_radius = 1\nratio = 2\n").is_err()
    );
}

// ---------------------------------------------------------------------------------------
// Sprinkling.

/// A region of `shape`'s proportions sized so that the final grains would fill it at a
/// solid fraction of 0.8.
fn sized(shape: Region, radii: &[f64]) -> Region {
    let solid: f64 = radii.iter().map(|r| std::f64::consts::PI * r * r).sum();
    shape.with_area(solid / 0.8)
}

/// No two scaled discs overlap and all lie in the region (a sweep along x).
fn check_placement(g: &GrainSet, region: &Region, fraction: f64) {
    let s: Vec<f64> = g.radius.iter().map(|r| fraction * r).collect();
    for (i, p) in g.position.iter().enumerate() {
        assert!(region.contains(*p, s[i]), "grain {i} at {p:?} sticks out");
    }
    let s_max = s.iter().copied().fold(0.0, f64::max);
    let mut order: Vec<usize> = (0..g.len()).collect();
    order.sort_by(|&a, &b| g.position[a][0].total_cmp(&g.position[b][0]));
    for (k, &i) in order.iter().enumerate() {
        for &j in &order[k + 1..] {
            let (dx, dy) = (
                g.position[j][0] - g.position[i][0],
                g.position[j][1] - g.position[i][1],
            );
            if dx > 2.0 * s_max {
                break;
            }
            let reach = s[i] + s[j];
            assert!(
                dx * dx + dy * dy >= reach * reach,
                "grains {i} and {j} overlap"
            );
        }
    }
}

#[test]
fn sprinkled_grains_do_not_overlap() {
    let d = SizeDistribution::new(SizeKind::A, MEAN, 4.0).unwrap();
    for n in [1_000, 10_000] {
        let radii = d.radii(n, 11);
        let shapes = [
            Region::Rectangle {
                width: 1.0,
                height: 2.5,
            },
            Region::Annulus {
                inner_radius: 1.0,
                outer_radius: 3.0,
            },
        ];
        for shape in shapes {
            let region = sized(shape, &radii);
            for fraction in [0.3, 0.1] {
                let start = Instant::now();
                let g = sprinkle(&region, &radii, fraction, 99).unwrap();
                let took = start.elapsed();
                println!(
                    "sprinkle {n:>6} grains, {:<9} fraction {fraction}: {:.1} ms",
                    region.shape(),
                    took.as_secs_f64() * 1e3
                );
                assert_eq!(g.radius, radii);
                assert_eq!(g, GrainSet::new(g.position.clone(), radii.clone()));
                check_placement(&g, &region, fraction);
                assert_eq!(g, sprinkle(&region, &radii, fraction, 99).unwrap());
                assert_ne!(
                    g.position,
                    sprinkle(&region, &radii, fraction, 98).unwrap().position
                );
            }
        }
    }
}

#[test]
fn sprinkle_at_the_thesis_size_and_into_a_beam() {
    let d = SizeDistribution::new(SizeKind::B, MEAN, 4.0).unwrap();
    let radii = d.radii(2_000, 3);
    for shape in [
        Region::Beam {
            length: 5.0,
            height: 1.0,
        },
        Region::Annulus {
            inner_radius: 0.0,
            outer_radius: 1.0,
        },
    ] {
        let region = sized(shape, &radii);
        let g = sprinkle(&region, &radii, 0.01, 1).unwrap();
        check_placement(&g, &region, 0.01);
    }
}

#[test]
fn sprinkle_errors() {
    let d = SizeDistribution::new(SizeKind::A, MEAN, 4.0).unwrap();
    let radii = d.radii(1_000, 1);
    let region = sized(
        Region::Rectangle {
            width: 1.0,
            height: 2.5,
        },
        &radii,
    );
    // At full size the random placement jams near 55% cover, far below 80%.
    let start = Instant::now();
    match sprinkle(&region, &radii, 1.0, 1) {
        Err(SampleError::NoRoom { index, total, .. }) => {
            println!(
                "full size: no room for grain {index} of {total} ({:.0} ms)",
                start.elapsed().as_secs_f64() * 1e3
            );
            assert!(index > 100 && index < total);
        }
        other => panic!("expected NoRoom, got {other:?}"),
    }
    for fraction in [0.0, -0.1, 1.5, f64::NAN] {
        assert!(
            matches!(
                sprinkle(&region, &radii, fraction, 1),
                Err(SampleError::Fraction(_))
            ),
            "{fraction}"
        );
    }
    let tiny = Region::Rectangle {
        width: 1e-4,
        height: 1e-2,
    };
    assert!(matches!(
        sprinkle(&tiny, &[1e-4], 1.0, 1),
        Err(SampleError::TooLarge { index: 0, .. })
    ));
    let ring = Region::Annulus {
        inner_radius: 1.0,
        outer_radius: 1.1,
    };
    assert!(matches!(
        sprinkle(&ring, &[0.01, 0.06], 1.0, 1),
        Err(SampleError::TooLarge { index: 1, .. })
    ));
    assert!(sprinkle(&ring, &[0.01, 0.04], 1.0, 1).is_ok());
    assert!(matches!(
        sprinkle(&region, &[1e-4, -1.0], 0.1, 1),
        Err(SampleError::Radius { index: 1, .. })
    ));
    for bad in [
        Region::Rectangle {
            width: 0.0,
            height: 1.0,
        },
        Region::Beam {
            length: 1.0,
            height: f64::INFINITY,
        },
        Region::Annulus {
            inner_radius: 2.0,
            outer_radius: 1.0,
        },
        Region::Annulus {
            inner_radius: -1.0,
            outer_radius: 1.0,
        },
    ] {
        assert!(
            matches!(sprinkle(&bad, &[1e-4], 0.1, 1), Err(SampleError::Region(_))),
            "{bad:?}"
        );
    }
    // No grains: nothing to place.
    assert!(sprinkle(&region, &[], 0.5, 1).unwrap().is_empty());
}

#[test]
fn regions() {
    let r = Region::Rectangle {
        width: 2.0,
        height: 5.0,
    };
    assert_eq!(r.area(), 10.0);
    assert!(r.contains([1.0, 1.0], 1.0));
    assert!(!r.contains([1.0, 1.0], 1.0 + 1e-12));
    assert!(!r.contains([-0.1, 1.0], 0.0));
    let a = Region::Annulus {
        inner_radius: 1.0,
        outer_radius: 3.0,
    };
    assert!((a.area() - 8.0 * std::f64::consts::PI).abs() < 1e-12);
    assert!(a.contains([2.0, 0.0], 1.0));
    assert!(!a.contains([0.0, 2.0], 1.01));
    assert!(!a.contains([0.5, 0.0], 0.0));
    assert!(!a.contains([0.0, 0.0], 5.0));
    let b = a.with_area(2.0 * a.area());
    assert!((b.area() / a.area() - 2.0).abs() < 1e-12);
    assert_eq!(a.bounding_box(), [-3.0, -3.0, 3.0, 3.0]);
}
