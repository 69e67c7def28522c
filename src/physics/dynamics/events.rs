//! The cut-offs as events: where a pair's torque jumps at its well's cut-off, the fast path
//! integrates the smooth torque of one side of every cut-off (each pair within reach pulls by
//! its well's formula continued beyond the cut-off, each pair beyond it not at all), finds where
//! a pair's margin crosses on the step's cubic Hermite interpolant, takes the step again to land
//! there, and goes on from there with that pair on the other side. No step straddles a jump of
//! the torque, so the loose tolerance's error control holds across a cut-off as anywhere else.

use super::RotorDynamics;
use crate::physics::integrator::OdeSystem;
use crate::physics::torque::{first_bits, set_bits, within_reach, SideMask, TorqueModel};
use std::cell::Cell;

/// How far (in cosine: 1e-9 is 1.3e-7 degrees at a 25 degree cut-off) a pair's margin may be on
/// the wrong side of its cut-off before it is an event, and the band a landing aims into: the
/// pair is switched where its margin is within this beyond the cut-off, moving on. At the
/// ball's speeds (0.1 to 3 rad/s) that is within 1e-8 s of the crossing: a torque impulse
/// orders of magnitude below the stepper's own errors.
pub(super) const LAND_TOL: f64 = 1e-9;

/// Landings tried for one event before the pairs beyond their cut-off are switched where the
/// step ends.
pub(super) const MAX_REDOS: u32 = 4;

/// The rotor's equations of motion under the smooth torques of [`TorqueModel::body_torque_within`]:
/// the pairs whose bit is set in `within` pull (by the formula continued beyond the cut-off),
/// the others do not; `events` false is the plain equations of motion.
pub(super) struct Sides<'s, 'a, M: TorqueModel> {
    pub(super) sys: &'s RotorDynamics<'a, M>,
    pub(super) events: bool,
    pub(super) within: Cell<SideMask>,
}

impl<'s, 'a, M: TorqueModel> Sides<'s, 'a, M> {
    /// The sides of the start `y0` (with the `margins` there): every pair within reach is
    /// within, or those of `carried` (the sides a settle went on with beyond a skin); events
    /// only where the model offers them and margins there.
    pub(super) fn new(
        sys: &'s RotorDynamics<'a, M>,
        margins: Option<&[(f64, f64)]>,
        carried: Option<SideMask>,
    ) -> Self {
        let events = margins.is_some() && sys.model.cutoff_events(sys.active);
        let within = margins
            .filter(|_| events)
            .map_or(0, |m| carried.unwrap_or_else(|| within_reach(m)));
        Sides {
            sys,
            events,
            within: Cell::new(within),
        }
    }

    /// +1 for a pair held within reach, -1 beyond.
    pub(super) fn side(&self, i: usize) -> f64 {
        if self.within.get() >> i & 1 == 1 {
            1.0
        } else {
            -1.0
        }
    }

    /// Switches the pairs of `flips` to the other side of their cut-off.
    pub(super) fn flip(&self, flips: SideMask) {
        self.within.set(self.within.get() ^ flips);
    }
}

impl<M: TorqueModel> OdeSystem<7> for Sides<'_, '_, M> {
    #[inline]
    fn rhs(&self, y: &[f64; 7], dy: &mut [f64; 7]) {
        if !self.events {
            return self.sys.derivative(y, dy);
        }
        let q = [y[0], y[1], y[2], y[3]];
        let nb = self
            .sys
            .model
            .body_torque_within(&q, self.sys.active, self.within.get());
        self.sys.derivative_under(y, nb, dy)
    }
}

/// What the margins of a step say.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Seen {
    /// No pair left its side.
    Quiet,
    /// A pair leaves its side within the step, first at this fraction of it: land there.
    Redo(f64),
    /// The step ends with these pairs (bits) at their cut-off, moving on across it: switch them.
    Flip(SideMask),
}

/// What the margins (m, dm/dt) of the pairs of `due` at a step's start (`before`) and end
/// (`now`), `h` apart, say with the pairs on the sides of `sides` (the other pairs are far
/// from their cut-offs).
pub(super) fn seen<M: TorqueModel>(
    sides: &Sides<'_, '_, M>,
    before: &[(f64, f64)],
    now: &[(f64, f64)],
    h: f64,
    due: SideMask,
) -> Seen {
    let mut first: Option<f64> = None;
    let mut flips: SideMask = 0;
    for i in each(due, now.len().min(before.len())) {
        let (a, b) = (before[i], now[i]);
        let side = sides.side(i);
        if let Some(s) = leaves(side, a, b, h) {
            first = Some(first.map_or(s, |f: f64| f.min(s)));
        } else if side * b.0 < 0.0 && side * b.1 < 0.0 {
            flips |= 1 << i;
        }
    }
    match first {
        Some(s) => Seen::Redo(s),
        None if flips != 0 => Seen::Flip(flips),
        None => Seen::Quiet,
    }
}

/// The pairs of `pairs` among `n`, ascending: the set bits below `n`, or every pair where
/// there are more than a [`SideMask`] has bits.
pub(super) fn each(pairs: SideMask, n: usize) -> impl Iterator<Item = usize> {
    let all = n > SideMask::BITS as usize;
    let bits = if all { 0 } else { pairs & first_bits(n) };
    (0..if all { n } else { 0 }).chain(set_bits(bits))
}

/// The first fraction s of a step at which a pair's margin, on its cubic Hermite interpolant
/// from (m0, dm0/dt) to (m1, dm1/dt) over `h`, goes more than [`LAND_TOL`] beyond its cut-off
/// on the wrong side of `side` (+1: the pair is held within reach), refined to where it is half
/// that beyond (or [`LAND_TOL`], where the stretch it leaves on begins past half); `None`
/// where it stays on its side. The cubic is split where its slope vanishes into stretches on
/// which it is monotone, so the first stretch that ends beyond holds the crossing.
pub(super) fn leaves(side: f64, (m0, r0): (f64, f64), (m1, r1): (f64, f64), h: f64) -> Option<f64> {
    let (g0, g1) = (side * m0, side * m1);
    let (d0, d1) = (side * r0 * h, side * r1 * h);
    let dg = g1 - g0;
    // the interpolant departs from the chord by at most a quarter of |d0 - dg| + |d1 - dg|
    if g0.min(g1) - 0.25 * ((d0 - dg).abs() + (d1 - dg).abs()) >= -LAND_TOL {
        return None;
    }
    // g(s) = g0 + d0 s + b s^2 + c s^3, g'(s) = d0 + 2 b s + 3 c s^2
    let (b, c) = (3.0 * dg - 2.0 * d0 - d1, d0 + d1 - 2.0 * dg);
    let g = |s: f64| g0 + s * (d0 + s * (b + s * c));
    let mut ends = [1.0; 3];
    for (k, r) in slope_roots(3.0 * c, 2.0 * b, d0).into_iter().enumerate() {
        ends[k] = r;
    }
    let mut lo = 0.0;
    for end in ends {
        let at_end = if end == 1.0 { g1 } else { g(end) };
        if at_end < -LAND_TOL {
            let target = if g(lo) >= -0.5 * LAND_TOL {
                -0.5 * LAND_TOL
            } else {
                -LAND_TOL
            };
            return Some(bisect(|s| g(s) - target, lo, end));
        }
        lo = end;
    }
    None
}

/// The roots of a s^2 + b s + c strictly within (0, 1), ascending (1.0 where there is none).
fn slope_roots(a: f64, b: f64, c: f64) -> [f64; 2] {
    let mut roots = [1.0; 2];
    let mut n = 0;
    let mut keep = |r: f64| {
        if r > 0.0 && r < 1.0 && r.is_finite() {
            roots[n] = r;
            n += 1;
        }
    };
    if a.abs() <= 1e-14 * (b.abs() + c.abs()) {
        if b != 0.0 {
            keep(-c / b);
        }
    } else {
        let disc = b * b - 4.0 * a * c;
        if disc > 0.0 {
            // the stable pair of formulas
            let q = -0.5 * (b + b.signum() * disc.sqrt());
            let (r1, r2) = (q / a, c / q);
            keep(r1.min(r2));
            keep(r1.max(r2));
        }
    }
    roots
}

/// The root of `f` in [lo, hi], f(lo) >= 0 > f(hi), by bisection to 1e-13.
fn bisect(f: impl Fn(f64) -> f64, mut lo: f64, mut hi: f64) -> f64 {
    while hi - lo > 1e-13 {
        let mid = 0.5 * (lo + hi);
        if f(mid) >= 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_margin_that_crosses_its_cut_off_is_found_where_it_crosses() {
        // m(t) = 0.01 - 0.2 t over a step of 0.1: crosses at t = 0.05, s = 0.5, and the landing
        // aims just beyond, within the band of LAND_TOL
        let h = 0.1;
        let s = leaves(1.0, (0.01, -0.2), (-0.01, -0.2), h).expect("a crossing");
        let m = 0.01 - 0.2 * s * h;
        assert!((-LAND_TOL..0.0).contains(&m), "m = {m} at s = {s}");
        // the same margin, the pair beyond reach: coming into reach is the event
        let s = leaves(-1.0, (-0.01, 0.2), (0.01, 0.2), h).expect("a crossing");
        let m = -0.01 + 0.2 * s * h;
        assert!((0.0..LAND_TOL).contains(&m), "m = {m} at s = {s}");
        // a margin that stays on its side is no event
        assert_eq!(leaves(1.0, (0.01, -0.05), (0.006, -0.03), h), None);
    }

    #[test]
    fn a_dip_across_and_back_within_a_step_is_found_at_its_first_crossing() {
        // m(t) = c + a (t - h/2)^2, its least c = -0.002 mid-step, both ends 0.01
        let h = 0.1;
        let c = -0.002;
        let a = (0.01 - c) / (h * h / 4.0);
        let s = leaves(1.0, (0.01, -a * h), (0.01, a * h), h).expect("a dip across");
        let t = s * h;
        let m = c + a * (t - h / 2.0).powi(2);
        assert!(m.abs() < LAND_TOL && t < h / 2.0, "m = {m} at t = {t}");
        // a dip that stays within reach is none
        let c = 1e-6;
        let a = (0.01 - c) / (h * h / 4.0);
        assert_eq!(leaves(1.0, (0.01, -a * h), (0.01, a * h), h), None);
    }
}
