//! The "coils" interaction restricted to the magnets near the active coils at one orientation:
//! the same torques to the bit as the whole model's while the ball stays within a skin of it,
//! with the far magnets' terms skipped.

use super::*;

/// The "coils" interaction for one active set near one orientation R0: each energised coil
/// with the magnets (in the rotor's order) within the cut-off plus [`NEAR_SKIN`] of it at R0.
/// While R stays within [`NEAR_SKIN`] of R0 no other magnet can come within reach (the angle
/// between R m and s changes by at most the angle of R0^T R), so the sums have the same
/// non-zero terms in the same order as the whole model's: the same torques to the bit. Beyond
/// the skin the torques (and the linearization) are those of lists built again where the ball
/// first went beyond it (the same bits again; up to four times in a chain, then
/// the whole model's), and the model offers no cut-off margins or events there; for another
/// active set it is the whole model.
#[derive(Debug, Clone)]
pub struct NearbyMagnets<'a> {
    full: &'a MagnetTorques,
    /// The active set the lists are for (the settle's own slice: see [`NearbyMagnets::is_for`]).
    active: &'a [Pair],
    r0: Matrix3<f64>,
    /// tr(R0^T R) = 1 + 2 cos(angle) at least this: R is within the skin.
    trace_min: f64,
    /// The energised coils' world axes, in the order of [`MagnetTorques::coils`] ...
    coils: Vec<Vector3<f64>>,
    /// ... and their nearby magnets (body frame): those of coil k at `starts[k]..starts[k + 1]`.
    pub(super) magnets: Vec<Vector3<f64>>,
    pub(super) starts: Vec<usize>,
    /// Each listed magnet's index in the rotor (ascending within a coil's lists).
    pub(super) ids: Vec<usize>,
    /// A bit for each (coil, magnet) pair of the lists (all of a [`SideMask`] beyond its 128).
    listed: SideMask,
    /// The lists built where the ball first went beyond this one's skin (at most
    /// [`MAX_REBUILDS`] deep): each settle builds its own, so the bits never depend on threads.
    beyond: std::sync::OnceLock<Box<NearbyMagnets<'a>>>,
    /// How many lists came before this one in the chain.
    depth: usize,
}

/// How many times the lists are built again beyond the skin before the whole model's sums
/// take over (a settle that turns the ball by more than about 100 degrees).
const MAX_REBUILDS: usize = 4;

impl<'a> NearbyMagnets<'a> {
    pub(super) fn new(full: &'a MagnetTorques, r0: &Matrix3<f64>, active: &'a [Pair]) -> Self {
        Self::at_depth(full, r0, active, 0)
    }

    fn at_depth(
        full: &'a MagnetTorques,
        r0: &Matrix3<f64>,
        active: &'a [Pair],
        depth: usize,
    ) -> Self {
        let cos_list = cos_within(full.well.max_attraction.0 + NEAR_SKIN + MARGIN_CAP);
        let (mut coils, mut magnets, mut starts) = (Vec::new(), Vec::new(), vec![0]);
        let mut ids = Vec::new();
        for c in MagnetTorques::coils(active) {
            let s = r0.tr_mul(&full.stator[c]);
            coils.push(full.stator[c]);
            let near = full
                .rotor
                .iter()
                .enumerate()
                .filter(|(_, m)| m.dot(&s) >= cos_list);
            for (j, m) in near {
                magnets.push(*m);
                ids.push(j);
            }
            starts.push(magnets.len());
        }
        NearbyMagnets {
            full,
            active,
            r0: *r0,
            trace_min: 1.0 + 2.0 * NEAR_SKIN.cos(),
            coils,
            listed: first_bits(magnets.len()),
            magnets,
            starts,
            ids,
            beyond: std::sync::OnceLock::new(),
            depth,
        }
    }

    /// Lists that hold every magnet in reach at `r` with `active` on: these within their skin,
    /// else those of the chain built beyond it (built here where missing); `None` for another
    /// active set or past the chain's end (then the whole model's sums are the same bits).
    fn lists_at(&self, r: &Matrix3<f64>, active: &[Pair]) -> Option<&Self> {
        if !self.is_for(active) {
            return None;
        }
        let mut lists = self;
        while !lists.within_skin(r) {
            if lists.depth >= MAX_REBUILDS {
                return None;
            }
            let depth = lists.depth + 1;
            lists = lists
                .beyond
                .get_or_init(|| Box::new(Self::at_depth(self.full, r, self.active, depth)));
        }
        Some(lists)
    }

    /// How many lists were built beyond the skin (the chain's length).
    #[cfg(test)]
    pub(super) fn rebuilds(&self) -> usize {
        self.beyond.get().map_or(0, |next| 1 + next.rebuilds())
    }

    /// Whether the lists are for `active`: the settle asks with the slice they were built for
    /// (held for their lifetime, so the same address and length are the same pairs), which is
    /// told by its address, without comparing the pairs; any other slice, pair by pair.
    #[inline]
    fn is_for(&self, active: &[Pair]) -> bool {
        std::ptr::eq(active, self.active) || active == self.active
    }

    /// Whether `r` is within the skin of the orientation the lists were built at.
    #[inline]
    fn within_skin(&self, r: &Matrix3<f64>) -> bool {
        self.r0.component_mul(r).sum() >= self.trace_min
    }

    /// The sum of the listed pairs' torques at `r` (within the skin: the whole model's).
    fn listed_torque(&self, r: &Matrix3<f64>) -> Vector3<f64> {
        let cos_cutoff = self.full.well.cos_cutoff;
        let mut tau = Vector3::zeros();
        for k in 0..self.coils.len() {
            let (s, magnets) = self.coil(k, r);
            for m in magnets {
                tau += self.full.well.pair_torque(m, &s, cos_cutoff);
            }
        }
        tau
    }

    /// The listed pairs' linearization at `r` (within the skin: the whole model's).
    fn listed_linearization(&self, r: &Matrix3<f64>) -> Option<Linearization> {
        let mut lin = MagnetTorques::no_linearization();
        let cos_far = self.full.well.cos_far;
        for k in 0..self.coils.len() {
            let (s, magnets) = self.coil(k, r);
            // a magnet beyond the margin's cap adds nothing (the same test as the call's)
            for m in magnets.iter().filter(|m| m.dot(&s) >= cos_far) {
                self.full.pair_linearization(m, &s, cos_far, &mut lin)?;
            }
        }
        Some(lin)
    }

    /// Whether the lists hold every magnet in reach at `r` with `active` on (and every magnet
    /// within the margin's cap beyond it).
    #[inline]
    fn covers(&self, r: &Matrix3<f64>, active: &[Pair]) -> bool {
        self.within_skin(r) && self.is_for(active)
    }

    /// Coil k's body-frame axis at `r` and its nearby magnets.
    #[inline]
    fn coil(&self, k: usize, r: &Matrix3<f64>) -> (Vector3<f64>, &[Vector3<f64>]) {
        (
            r.tr_mul(&self.coils[k]),
            &self.magnets[self.starts[k]..self.starts[k + 1]],
        )
    }

    /// `f(i, s)` for each listed pair whose bit is set in `pairs`, in ascending order (the
    /// sums' order: coil by coil, each coil's magnets in the lists' order), with `s` its coil's
    /// body-frame axis at `r`, turned when the coil's first such pair comes.
    #[inline]
    fn each_listed(
        &self,
        r: &Matrix3<f64>,
        pairs: SideMask,
        mut f: impl FnMut(usize, &Vector3<f64>),
    ) {
        let mut s = Vector3::zeros();
        let (mut next, mut end) = (0, 0);
        for i in set_bits(pairs & self.listed) {
            if i >= end {
                while self.starts[next + 1] <= i {
                    next += 1;
                }
                s = r.tr_mul(&self.coils[next]);
                end = self.starts[next + 1];
                next += 1;
            }
            f(i, &s);
        }
    }
}

impl TorqueModel for NearbyMagnets<'_> {
    fn torque_energy(&self, r: &Matrix3<f64>, active: &[Pair]) -> (Vector3<f64>, f64) {
        // the energy counts every magnet (the well is constant, not zero, beyond its cut-off)
        self.full.torque_energy(r, active)
    }

    fn torque(&self, r: &Matrix3<f64>, active: &[Pair]) -> Vector3<f64> {
        r * self.body_torque(r, active)
    }

    fn body_torque(&self, r: &Matrix3<f64>, active: &[Pair]) -> Vector3<f64> {
        match self.lists_at(r, active) {
            Some(lists) => lists.listed_torque(r),
            None => self.full.body_torque(r, active),
        }
    }

    fn linearize(&self, r: &Matrix3<f64>, active: &[Pair]) -> Option<Linearization> {
        match self.lists_at(r, active) {
            Some(lists) => lists.listed_linearization(r),
            None => self.full.linearize(r, active),
        }
    }

    fn stiffness_scale(&self) -> Option<f64> {
        self.full.stiffness_scale()
    }

    /// The cut-offs as events where the well's torque jumps at them and the lists hold at most
    /// [`MAX_EVENT_PAIRS`] (coil, magnet) pairs (the bits of [`TorqueModel::body_torque_within`]'s mask), for
    /// the active set the lists were built for.
    fn cutoff_events(&self, active: &[Pair]) -> bool {
        self.full.well.cutoff_jump && self.magnets.len() <= MAX_EVENT_PAIRS && self.is_for(active)
    }

    /// Each energised coil pulling only the nearby magnets whose bit (their index in the lists)
    /// is set in `within`, by the well's formula continued beyond the cut-off; beyond the skin
    /// (where the lists may miss a magnet in reach) [`TorqueModel::body_torque`], the whole
    /// model's bits.
    fn body_torque_within(&self, q: &[f64; 4], active: &[Pair], within: SideMask) -> Vector3<f64> {
        let r = rotation_matrix(q[0], q[1], q[2], q[3]);
        if !self.covers(&r, active) {
            return self.body_torque(&r, active);
        }
        let mut tau = Vector3::zeros();
        self.each_listed(&r, within, |i, s| {
            tau += self.full.well.pair_torque_continued(&self.magnets[i], s);
        });
        tau
    }

    /// Every energised coil's nearby magnets, in the lists' order; none beyond the skin (where
    /// other magnets may come within reach).
    fn cutoff_margins(
        &self,
        r: &Matrix3<f64>,
        w: &Vector3<f64>,
        active: &[Pair],
        out: &mut Vec<(f64, f64)>,
    ) -> bool {
        if !self.covers(r, active) || !self.full.well.cutoff_jump {
            return false;
        }
        for k in 0..self.coils.len() {
            let (s, magnets) = self.coil(k, r);
            out.extend(
                magnets
                    .iter()
                    .map(|m| self.full.well.cutoff_margin(m, &s, w)),
            );
        }
        true
    }

    /// Lists built at `r` (one deeper in the chain) for a settle with cut-off events that goes
    /// on beyond this one's skin, and the sides `within` of this one's pairs (a bit for each
    /// held within reach) carried over to theirs by (coil, magnet); a pair new to them is
    /// beyond its cut-off (at `r`, within this skin, no magnet outside these lists is within
    /// reach). `None` for wells without a cut-off jump, another active set, past
    /// `MAX_REBUILDS` lists, more pairs than [`MAX_EVENT_PAIRS`] on either lists, or where the
    /// skin's promise fails: a new pair within its cut-off at `r`, or a pair held within reach
    /// that the new lists leave out.
    fn continued_at(
        &self,
        r: &Matrix3<f64>,
        active: &[Pair],
        within: SideMask,
    ) -> Option<(Self, SideMask)> {
        if !self.full.well.cutoff_jump
            || !self.is_for(active)
            || self.depth >= MAX_REBUILDS
            || self.magnets.len() > MAX_EVENT_PAIRS
        {
            return None;
        }
        let next = Self::at_depth(self.full, r, self.active, self.depth + 1);
        if next.magnets.len() > MAX_EVENT_PAIRS {
            return None;
        }
        let held = |i: usize| within >> i & 1 == 1;
        let mut carried: SideMask = 0;
        for k in 0..self.coils.len() {
            let (mut i, end) = (self.starts[k], self.starts[k + 1]);
            let s = r.tr_mul(&self.coils[k]);
            for j in next.starts[k]..next.starts[k + 1] {
                // both lists in the rotor's order: the old pairs before this one are left out
                while i < end && self.ids[i] < next.ids[j] {
                    if held(i) {
                        return None;
                    }
                    i += 1;
                }
                if i < end && self.ids[i] == next.ids[j] {
                    if held(i) {
                        carried |= 1 << j;
                    }
                    i += 1;
                } else if next.magnets[j].dot(&s) >= self.full.well.cos_cutoff {
                    return None;
                }
            }
            if (i..end).any(held) {
                return None;
            }
        }
        Some((next, carried))
    }

    fn cutoff_margins_of(
        &self,
        r: &Matrix3<f64>,
        w: &Vector3<f64>,
        active: &[Pair],
        pairs: SideMask,
        out: &mut [(f64, f64)],
    ) -> bool {
        if !self.covers(r, active) || !self.full.well.cutoff_jump {
            return false;
        }
        self.each_listed(r, pairs & first_bits(out.len()), |i, s| {
            out[i] = self.full.well.cutoff_margin(&self.magnets[i], s, w);
        });
        true
    }
}
