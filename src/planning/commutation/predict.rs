//! The cheap predictions of where a set leaves the ball, before the engine settles it: the
//! equilibrium of springs in place of the wells (Wahba's problem: Davenport's closed form, SVD
//! where it is ill-conditioned), and springs weighted as the wells pull.

use super::*;

/// The cheap prediction of where a set leaves the ball from `q`: the rotation that brings its
/// magnets as close to their coils as it can in the least-squares sense (Wahba's problem,
/// solved by SVD), applied to `q`. It is the equilibrium of springs in place of the wells, good
/// for ranking proposals before the engine settles the best of them.
pub fn predicted_orientation(
    torques: &MagnetTorques,
    q: &Orientation,
    set: &[Pair],
) -> Orientation {
    wahba(torques, q, set, |_| 1.0)
}

/// A finer cheap prediction than [`predicted_orientation`], for sets whose magnets lie across
/// the well's shoulder: springs weighted as the wells pull (each pair's pull g(d) over sin d;
/// nothing beyond the maximum attraction distance), first at `guess`, then at each prediction,
/// `iterations` times. A well pulls a far magnet less than a spring would, so the prediction
/// leans towards the near pairs, as the settle does. Unweighted springs when no pair pulls at
/// `guess`.
pub fn predicted_in_wells(
    torques: &MagnetTorques,
    q: &Orientation,
    set: &[Pair],
    guess: &Orientation,
    iterations: usize,
) -> Orientation {
    let rq = q.to_rotation_matrix();
    let mut qp = *guess;
    for k in 0..iterations {
        let r = qp.to_rotation_matrix();
        // the weights at the prediction, the springs from q: one pass, no weights kept
        let (mut b, mut total, mut pulls) = (nalgebra::Matrix3::zeros(), 0.0, false);
        for p in set {
            let w = well_weight(torques, &r, *p);
            pulls |= pulls_at_all(w);
            b += spring(torques, &rq, *p, w);
            total += w.abs();
        }
        if !pulls {
            return match k {
                0 => predicted_orientation(torques, q, set),
                _ => qp,
            };
        }
        qp = turned(&b, total, q);
    }
    qp
}

/// The first weighing of [`predicted_in_wells`] for many sets drawn from the same pairs, from
/// one orientation (the guess the orientation itself): a pair's weight there and its term of
/// Wahba's matrix depend on the pair alone, so they are computed once, and each set sums its
/// pairs' terms in its own order with the same arithmetic. [`FirstWeighing::predicted`] has
/// the bits of `predicted_in_wells(torques, q, set, q, 1)`.
pub struct FirstWeighing<'a> {
    torques: &'a MagnetTorques,
    q: Orientation,
    /// The pairs, and each one's weight and term, in the same order.
    pairs: &'a [Pair],
    terms: Vec<(f64, nalgebra::Matrix3<f64>)>,
}

impl<'a> FirstWeighing<'a> {
    /// The weights and terms of `pairs` with the ball at `q`.
    pub fn new(torques: &'a MagnetTorques, q: &Orientation, pairs: &'a [Pair]) -> Self {
        let r = q.to_rotation_matrix();
        let terms = (pairs.iter())
            .map(|p| {
                let w = well_weight(torques, &r, *p);
                (w, spring(torques, &r, *p, w))
            })
            .collect();
        FirstWeighing {
            torques,
            q: *q,
            pairs,
            terms,
        }
    }

    /// `predicted_in_wells(torques, q, set, q, 1)` for the set of the pairs at `indices` (of
    /// those the weighing was made for, in that order), from their terms.
    pub fn predicted(&self, indices: &[usize]) -> Orientation {
        let (mut b, mut total, mut pulls) = (nalgebra::Matrix3::zeros(), 0.0, false);
        for &i in indices {
            let (w, term) = &self.terms[i];
            pulls |= pulls_at_all(*w);
            b += term;
            total += w.abs();
        }
        if !pulls {
            let set: Vec<Pair> = indices.iter().map(|&i| self.pairs[i]).collect();
            return predicted_orientation(self.torques, &self.q, &set);
        }
        turned(&b, total, &self.q)
    }
}

/// Whether a weight keeps the weighted springs in play: any but one at or below 0 (a NaN too,
/// as "not every weight at or below 0" had it).
fn pulls_at_all(w: f64) -> bool {
    w > 0.0 || w.is_nan()
}

/// A pair's spring weight in the wells with the ball turned by `r`: its pull g(d) over sin d.
fn well_weight(torques: &MagnetTorques, r: &nalgebra::Rotation3<f64>, p: Pair) -> f64 {
    let d = pair_gap(torques, r, p).0.max(1e-9);
    torques.well.g(d) / d.sin()
}

/// A pair's term of Wahba's attitude profile matrix, the ball turned by `r`: `w` times its
/// coil times its magnet's transpose.
fn spring(
    torques: &MagnetTorques,
    r: &nalgebra::Rotation3<f64>,
    p: Pair,
    w: f64,
) -> nalgebra::Matrix3<f64> {
    let a = r * torques.rotor[p.magnet.0];
    w * torques.stator[p.coil.0] * a.transpose()
}

/// The rotation that brings `set`'s magnets (the ball at `q`) nearest their coils with the
/// `i`th pair weighed by `weight(i)` (Wahba's problem), applied to `q`.
fn wahba(
    torques: &MagnetTorques,
    q: &Orientation,
    set: &[Pair],
    weight: impl Fn(usize) -> f64,
) -> Orientation {
    let r = q.to_rotation_matrix();
    let mut b = nalgebra::Matrix3::zeros();
    let mut total = 0.0;
    for (i, p) in set.iter().enumerate() {
        let w = weight(i);
        b += spring(torques, &r, *p, w);
        total += w.abs();
    }
    turned(&b, total, q)
}

/// The solution of Wahba's problem for the attitude profile matrix `b` (the weights summing
/// to `total`, in absolute value), applied to `q`; `q` itself when there is none.
fn turned(b: &nalgebra::Matrix3<f64>, total: f64, q: &Orientation) -> Orientation {
    match wahba_closed_form(b, total).or_else(|| wahba_svd(b)) {
        Some(turn) => turn * q,
        None => *q,
    }
}

/// Wahba's problem in closed form (Davenport's q-method as QUEST solves it): the largest root
/// of the characteristic quartic of Davenport's matrix by Newton's method from `total` (the sum
/// of the weights, which bounds it from above, so the iteration falls monotonically onto it),
/// then its eigenvector as the largest column of the adjugate of (K - lambda I). `None` when
/// that root is (nearly) double, where the optimal rotation is not unique or not well
/// conditioned (one pair, or pairs in a line): the SVD decides those. `b` is the attitude
/// profile matrix, the sum of weight * coil * magnet^T.
pub(super) fn wahba_closed_form(
    b: &nalgebra::Matrix3<f64>,
    total: f64,
) -> Option<UnitQuaternion<f64>> {
    if !(total > 0.0 && total.is_finite()) {
        return None;
    }
    let s = b + b.transpose();
    let sigma = b.trace();
    let z = Vector3::new(
        b[(1, 2)] - b[(2, 1)],
        b[(2, 0)] - b[(0, 2)],
        b[(0, 1)] - b[(1, 0)],
    );
    // tr(adj S): the sum of S's principal 2x2 minors.
    let kappa = s[(1, 1)] * s[(2, 2)] - s[(1, 2)] * s[(2, 1)] + s[(0, 0)] * s[(2, 2)]
        - s[(0, 2)] * s[(2, 0)]
        + s[(0, 0)] * s[(1, 1)]
        - s[(0, 1)] * s[(1, 0)];
    let delta = s.determinant();
    let sz = s * z;
    let (a, bb) = (sigma * sigma - kappa, sigma * sigma + z.dot(&z));
    let (c, d) = (delta + z.dot(&sz), sz.dot(&sz));
    let c0 = a * bb + c * sigma - d;
    let mut lambda = total;
    for _ in 0..60 {
        let l2 = lambda * lambda;
        let f = l2 * l2 - (a + bb) * l2 - c * lambda + c0;
        let df = 4.0 * l2 * lambda - 2.0 * (a + bb) * lambda - c;
        if df <= 0.0 || !df.is_finite() {
            break;
        }
        let step = f / df;
        lambda -= step;
        if step.abs() <= 1e-15 * total {
            break;
        }
    }
    // K - lambda I, K = [[S - sigma I, z], [z^T, sigma]] (vector part first).
    let mut m = nalgebra::Matrix4::zeros();
    m.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&(s - nalgebra::Matrix3::identity() * (sigma + lambda)));
    m.fixed_view_mut::<3, 1>(0, 3).copy_from(&z);
    m.fixed_view_mut::<1, 3>(3, 0).copy_from(&z.transpose());
    m[(3, 3)] = sigma - lambda;
    let adj = adjugate4(&m);
    let (col, norm) = (0..4)
        .map(|j| (j, adj.column(j).norm()))
        .fold((0, 0.0), |best, c| if c.1 > best.1 { c } else { best });
    // The adjugate is the product of the three other roots' gaps times the eigenvector's outer
    // product; a root that is (nearly) double leaves it near zero, and the root and its vector
    // lose digits as the gaps shrink. The roots lie within +-total: a product of gaps above
    // 1e-3 total^3 keeps every gap above 2.5e-4 total and the vector good to about 1e-9.
    if norm.is_nan() || norm <= 1e-3 * total * total * total {
        return None;
    }
    let v = adj.column(col) / norm;
    // Davenport's quaternion is the frame rotation (attitude matrix); the turn that carries
    // the magnets onto the coils is its conjugate.
    let quat = nalgebra::Quaternion::new(v[3], -v[0], -v[1], -v[2]);
    Some(UnitQuaternion::from_quaternion(quat))
}

/// The adjugate of a 4x4 matrix (cofactors, transposed): each cofactor as the 3x3 minor's
/// determinant expanded along its first row, read from a plain array with the index sets
/// fixed (no bounds checks, no closures on the way).
fn adjugate4(m: &nalgebra::Matrix4<f64>) -> nalgebra::Matrix4<f64> {
    const OTHERS: [[usize; 3]; 4] = [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]];
    // nalgebra stores by columns: cols[c][r] is m[(r, c)]
    let cols: [[f64; 4]; 4] = m.data.0;
    let mut adj = [[0.0; 4]; 4];
    for (j, column) in adj.iter_mut().enumerate() {
        for (i, entry) in column.iter_mut().enumerate() {
            // entry (i, j) is the cofactor of (j, i)
            let (rows, cs) = (OTHERS[j], OTHERS[i]);
            let e = |r: usize, c: usize| cols[cs[c]][rows[r]];
            let minor = e(0, 0) * (e(1, 1) * e(2, 2) - e(1, 2) * e(2, 1))
                - e(0, 1) * (e(1, 0) * e(2, 2) - e(1, 2) * e(2, 0))
                + e(0, 2) * (e(1, 0) * e(2, 1) - e(1, 1) * e(2, 0));
            let sign = if (i + j) % 2 == 0 { 1.0 } else { -1.0 };
            *entry = sign * minor;
        }
    }
    nalgebra::Matrix4::from_data(nalgebra::ArrayStorage(adj))
}

/// Wahba's problem by SVD of the attitude profile matrix `b`, for the cases the closed form
/// leaves (a double root).
pub(super) fn wahba_svd(b: &nalgebra::Matrix3<f64>) -> Option<UnitQuaternion<f64>> {
    let svd = b.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return None;
    };
    let d = (u * v_t).determinant().signum();
    let m = u * nalgebra::Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * v_t;
    let rot = nalgebra::Rotation3::from_matrix_unchecked(m);
    Some(UnitQuaternion::from_rotation_matrix(&rot))
}
