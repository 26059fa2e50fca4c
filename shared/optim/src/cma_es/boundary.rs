//! Bound handling of CMA-ES: the search distribution lives on the whole real line in each free
//! coordinate, and a point y is evaluated (and asked) at T(y), a periodic, C¹, piecewise
//! quadratic–linear map of the line onto the coordinate's interval [lo, hi] (the idea of
//! pycma's default `BoundTransform`, written here from that description).
//!
//! With width w = hi − lo and tail a = 0.05 w, y is first folded by mirroring into
//! [lo − a, hi + a] (period 2 (w + 2a)), then
//!
//! - T(u) = u on [lo + a, hi − a] (the interior is searched unchanged),
//! - T(u) = lo + (u − lo + a)² / (4a) on [lo − a, lo + a], and symmetrically at hi.
//!
//! T is continuous with a continuous slope (0 at lo − a and hi + a, 1 in the interior), so no
//! asked point leaves the box, a point on a bound is reached smoothly (the objective near
//! a bound optimum stays quadratic in y, and CMA-ES converges there as in the interior), and
//! nothing piles up on the faces. Dimensions with lo = hi are fixed: the search runs in the
//! free dimensions only ([`BoxMap::dim`]) and fixed ones are always asked at their value.

use super::super::random::Random;
use super::super::space::Space;

/// Tail width a as a fraction of the interval's width.
const TAIL: f64 = 0.05;

/// The map between the search variables (free dimensions, real line) and the scaled box.
#[derive(Debug, Clone)]
pub(super) struct BoxMap {
    /// Scaled bounds of every dimension.
    bounds: Vec<(f64, f64)>,
    /// Indices of the free dimensions (lo < hi).
    free: Vec<usize>,
}

impl BoxMap {
    pub fn new(space: &Space) -> BoxMap {
        let bounds: Vec<(f64, f64)> = (0..space.dim()).map(|i| space.z_bounds(i)).collect();
        let free = (0..bounds.len()).filter(|&i| bounds[i].0 < bounds[i].1).collect();
        BoxMap { bounds, free }
    }

    /// Dimension of the search: the number of free parameters.
    pub fn dim(&self) -> usize {
        self.free.len()
    }

    /// The scaled point (all dimensions, in the box) at which search point `y` is evaluated.
    pub fn to_box(&self, y: &[f64]) -> Vec<f64> {
        let mut z: Vec<f64> = self.bounds.iter().map(|b| b.0).collect();
        for (&i, &v) in self.free.iter().zip(y) {
            let (lo, hi) = self.bounds[i];
            z[i] = (lo + (hi - lo) * unit_map(v_unit(v, lo, hi))).clamp(lo, hi);
        }
        z
    }

    /// A search point that maps to the scaled point `z` (in the box): T's inverse on the
    /// central period.
    pub fn preimage(&self, z: &[f64]) -> Vec<f64> {
        self.free
            .iter()
            .map(|&i| {
                let (lo, hi) = self.bounds[i];
                lo + (hi - lo) * unit_inverse(((z[i] - lo) / (hi - lo)).clamp(0.0, 1.0))
            })
            .collect()
    }

    /// A search point whose image is uniform in the box.
    pub fn random_point(&self, rng: &mut Random) -> Vec<f64> {
        let z: Vec<f64> =
            self.bounds.iter().map(|&(lo, hi)| if lo < hi { lo + rng.uniform() * (hi - lo) } else { lo }).collect();
        self.preimage(&z)
    }

    /// Shifts each coordinate of `y` by whole periods of T into the central period
    /// [lo − a, lo − a + 2 (w + 2a)), which changes no image: keeps the mean from drifting.
    pub fn wrap(&self, y: &mut [f64]) {
        for (&i, v) in self.free.iter().zip(y.iter_mut()) {
            let (lo, hi) = self.bounds[i];
            let w = hi - lo;
            if v.is_finite() {
                *v = lo + w * ((v_unit(*v, lo, hi) + TAIL).rem_euclid(period()) - TAIL);
            }
        }
    }
}

/// A coordinate in units of its interval: 0 at lo, 1 at hi.
fn v_unit(v: f64, lo: f64, hi: f64) -> f64 {
    (v - lo) / (hi - lo)
}

/// The period of T on the unit interval.
fn period() -> f64 {
    2.0 * (1.0 + 2.0 * TAIL)
}

/// T for the interval [0, 1]; see the module docs. A non-finite input maps to the centre.
fn unit_map(t: f64) -> f64 {
    if !t.is_finite() {
        return 0.5;
    }
    let p = period();
    let mut s = (t + TAIL).rem_euclid(p);
    if s > p / 2.0 {
        s = p - s;
    }
    let u = s - TAIL;
    let z = if u < TAIL {
        (u + TAIL).powi(2) / (4.0 * TAIL)
    } else if u > 1.0 - TAIL {
        1.0 - (1.0 + TAIL - u).powi(2) / (4.0 * TAIL)
    } else {
        u
    };
    z.clamp(0.0, 1.0)
}

/// The inverse of [`unit_map`] on [−a, 1 + a], for z in [0, 1].
fn unit_inverse(z: f64) -> f64 {
    if z < TAIL {
        -TAIL + (4.0 * TAIL * z).sqrt()
    } else if z > 1.0 - TAIL {
        1.0 + TAIL - (4.0 * TAIL * (1.0 - z)).sqrt()
    } else {
        z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_map_is_onto_the_interval_periodic_and_continuously_differentiable() {
        let slope = |t: f64| (unit_map(t + 1e-7) - unit_map(t - 1e-7)) / 2e-7;
        for k in -2000..2000 {
            let t = k as f64 * 0.0137;
            let z = unit_map(t);
            assert!((0.0..=1.0).contains(&z), "T({t}) = {z}");
            assert!((unit_map(t + period()) - z).abs() < 1e-12);
            assert!((slope(t).abs() - 1.0).max(0.0) < 1e-6, "slope {} at {t}", slope(t));
        }
        // Identity inside, flat at lo − a and hi + a, slope 1 where the tails meet the interior.
        assert_eq!(unit_map(0.5), 0.5);
        assert!(slope(-TAIL).abs() < 1e-6 && slope(1.0 + TAIL).abs() < 1e-6);
        assert!((slope(TAIL) - 1.0).abs() < 1e-6 && (slope(1.0 - TAIL) - 1.0).abs() < 1e-6);
        assert_eq!((unit_map(-TAIL), unit_map(1.0 + TAIL)), (0.0, 1.0));
        // The mirror copy runs backwards.
        assert!((unit_map(1.0 + 2.0 * TAIL + 0.3) - 0.7).abs() < 1e-12);
    }

    #[test]
    fn inverse_round_trips_and_wrap_keeps_the_image() {
        for k in 0..=1000 {
            let z = k as f64 / 1000.0;
            assert!((unit_map(unit_inverse(z)) - z).abs() < 1e-12, "z = {z}");
        }
        let space = Space::new(&[0.0, 5.0, -1.0], &[2.0, 5.0, 3.0], None, None).unwrap();
        let map = BoxMap::new(&space);
        assert_eq!(map.dim(), 2, "the fixed parameter is not searched");
        let mut y = vec![17.3, -40.2];
        let before = map.to_box(&y);
        map.wrap(&mut y);
        assert!(y.iter().all(|v| (-TAIL..2.0 + 3.0 * TAIL).contains(v)), "{y:?}");
        let after = map.to_box(&y);
        assert!(before.iter().zip(&after).all(|(a, b)| (a - b).abs() < 1e-12), "{before:?} {after:?}");
        assert_eq!(after[1], 0.0, "a fixed parameter sits at its value");
        let z = vec![0.0, 0.0, 0.99];
        assert!(map.to_box(&map.preimage(&z)).iter().zip(&z).all(|(a, b)| (a - b).abs() < 1e-12));
    }
}
