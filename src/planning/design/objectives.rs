//! What a layout is judged by, from its plans about the design's axes: the mean of the worst
//! quarter of the axis errors (a tail that does not hang on one axis, unlike the worst, which
//! is reported beside it), the median axis error, the worst final orientation error, the
//! median and the worst steps, and the coil count, all to be made smaller. A layout that
//! breaks the separations is not planned: its objectives are [`PENALTY`] plus its shortfall,
//! worse than any planned one.

/// One axis's plan, as a sweep's row reports it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisResult {
    /// The plan's worst cumulative axis error, degrees.
    pub axis_error_deg: f64,
    /// Its steps.
    pub steps: usize,
    /// Where it ends against the target orientation, degrees.
    pub final_error_deg: f64,
}

/// The objectives of a layout (every one smaller is better) and its worst axis error.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Objectives {
    /// The worst axis error over the axes, degrees: reported, not optimised (one unlucky axis
    /// moves it; [`Objectives::tail_axis_error_deg`] is what the search ranks on).
    pub worst_axis_error_deg: f64,
    /// The mean of the worst quarter of the axis errors ([`tail_mean`]), degrees.
    pub tail_axis_error_deg: f64,
    /// The median axis error, degrees.
    pub median_axis_error_deg: f64,
    /// The worst final orientation error, degrees.
    pub worst_final_error_deg: f64,
    /// The median steps.
    pub median_steps: f64,
    /// The most steps.
    pub worst_steps: f64,
    /// The coils.
    pub coils: f64,
}

/// The objectives' names, in the order of [`Objectives::values`], as `front.csv` and
/// `history.csv` head their columns.
pub const NAMES: [&str; 6] = [
    "tail_axis_error_deg",
    "median_axis_error_deg",
    "worst_final_error_deg",
    "median_steps",
    "worst_steps",
    "coils",
];

/// What a layout that breaks the separations scores on every objective (plus its shortfall).
pub const PENALTY: f64 = 1000.0;

/// The median of `v` (the mean of the middle two of an even count; 0 when empty).
pub fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    match s.len() {
        0 => 0.0,
        n if n % 2 == 1 => s[n / 2],
        n => 0.5 * (s[n / 2 - 1] + s[n / 2]),
    }
}

/// The mean of the worst quarter of `v` (its largest `ceil(len / 4)` values; 0 when empty):
/// the conditional value at risk at 75%, a tail statistic that one axis moves by at most a
/// quarter as much as it moves the worst.
pub fn tail_mean(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(|a, b| b.total_cmp(a));
    let k = s.len().div_ceil(4);
    match k {
        0 => 0.0,
        _ => s[..k].iter().sum::<f64>() / k as f64,
    }
}

impl Objectives {
    /// The objectives of a layout of `coils` coils from its plans' results.
    pub fn from_axes(results: &[AxisResult], coils: usize) -> Objectives {
        let errors: Vec<f64> = results.iter().map(|r| r.axis_error_deg).collect();
        let steps: Vec<f64> = results.iter().map(|r| r.steps as f64).collect();
        let worst = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
        Objectives {
            worst_axis_error_deg: worst(&errors),
            tail_axis_error_deg: tail_mean(&errors),
            median_axis_error_deg: median(&errors),
            worst_final_error_deg: worst(
                &results
                    .iter()
                    .map(|r| r.final_error_deg)
                    .collect::<Vec<_>>(),
            ),
            median_steps: median(&steps),
            worst_steps: worst(&steps),
            coils: coils as f64,
        }
    }

    /// The objectives of a layout that breaks the separations by `violation_deg`.
    pub fn penalised(violation_deg: f64, coils: usize) -> Objectives {
        let p = PENALTY + violation_deg;
        Objectives {
            worst_axis_error_deg: p,
            tail_axis_error_deg: p,
            median_axis_error_deg: p,
            worst_final_error_deg: p,
            median_steps: p,
            worst_steps: p,
            coils: coils as f64,
        }
    }

    /// The objectives the search ranks on, in the order of [`NAMES`] (the worst axis error
    /// is not among them).
    pub fn values(&self) -> [f64; 6] {
        [
            self.tail_axis_error_deg,
            self.median_axis_error_deg,
            self.worst_final_error_deg,
            self.median_steps,
            self.worst_steps,
            self.coils,
        ]
    }

    /// Whether `self` is no worse than `other` on every objective and better on one.
    pub fn dominates(&self, other: &Objectives) -> bool {
        let (a, b) = (self.values(), other.values());
        a.iter().zip(&b).all(|(x, y)| x <= y) && a.iter().zip(&b).any(|(x, y)| x < y)
    }
}

/// The indices of `all` that no other entry dominates, in their order.
pub fn non_dominated(all: &[Objectives]) -> Vec<usize> {
    (0..all.len())
        .filter(|&i| !all.iter().any(|o| o.dominates(&all[i])))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn objectives_are_the_tails_worsts_and_medians_of_the_axes() {
        let r = |e: f64, s: usize, f: f64| AxisResult {
            axis_error_deg: e,
            steps: s,
            final_error_deg: f,
        };
        let o = Objectives::from_axes(
            &[
                r(3.0, 7, 0.2),
                r(8.0, 10, 0.9),
                r(1.0, 5, 0.4),
                r(4.0, 12, 0.1),
            ],
            16,
        );
        // the worst quarter of four axes is the worst one
        assert_eq!(o.values(), [8.0, 3.5, 0.9, 8.5, 12.0, 16.0]);
        assert_eq!(o.worst_axis_error_deg, 8.0);
        assert_eq!(tail_mean(&[1.0, 9.0, 2.0, 3.0, 7.0, 4.0, 5.0, 6.0]), 8.0);
        assert_eq!(
            tail_mean(&[1.0, 9.0, 2.0, 3.0, 7.0]),
            8.0,
            "ceil(5 / 4) = 2"
        );
        assert_eq!(tail_mean(&[]), 0.0);
        let p = Objectives::penalised(2.0, 12);
        assert!(o.dominates(&Objectives { coils: 17.0, ..o }));
        assert!(!o.dominates(&o));
        assert!(
            !p.dominates(&o) && !o.dominates(&p),
            "fewer coils keep the penalised one"
        );
        assert_eq!(
            non_dominated(&[o, Objectives { coils: 17.0, ..o }, p]),
            [0, 2]
        );
    }
}
