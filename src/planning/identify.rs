//! Identification for the closed loop: which wells the motor really has, judged by the steps it
//! was measured to take. A fixed family of candidate models (the model's own wells first, then
//! gaussian wells of several widths and cosine wells, each at several reaches, each with the
//! pair interaction and with every coil pulling) predicts every measured step (the ball at rest
//! where it was measured, the step's set switched on, settled); a candidate is scored by the
//! median of its prediction errors. Equilibria depend on the wells' shape, not their
//! strength; the strength (against the model's body: its inertia and damping) decides only
//! which basin a step ends in, so each shape is tried at a few fractions of the model's
//! single-pair stiffness. Everything is counted, nothing timed: the same measurements give the
//! same choice on any machine and thread count.

use crate::model::geometry::{Degrees, Orientation, Pair, Radians};
use crate::physics::dynamics::settle;
use crate::physics::torque::{Interaction, MagnetTorques, Well, WellShape};
use crate::planning::commutation::Motor;
use rayon::prelude::*;

/// Widths (degrees) of the gaussian candidates.
pub const GAUSSIAN_WIDTHS_DEG: [f64; 7] = [5.0, 7.0, 10.0, 14.0, 20.0, 28.0, 40.0];
/// Reaches (maximum attraction distances, degrees) of the candidates; a gaussian's reach is at
/// least its width (where its pull peaks).
pub const REACHES_DEG: [f64; 7] = [15.0, 20.0, 25.0, 30.0, 40.0, 50.0, 60.0];
/// Stiffnesses of the candidates, as fractions of the model's single-pair stiffness.
pub const STIFFNESS_FRACTIONS: [f64; 5] = [0.125, 0.25, 0.5, 1.0, 2.0];

/// One measured step: the ball at rest at `from`, `active` switched on, measured at `to`.
#[derive(Debug, Clone, PartialEq)]
pub struct Observation {
    pub from: Orientation,
    pub active: Vec<Pair>,
    pub to: Orientation,
}

/// A candidate model of the wells.
#[derive(Debug, Clone)]
pub struct Candidate {
    pub torques: MagnetTorques,
    /// What it is, in words ("cosine wells reaching 40 deg, every coil pulls").
    pub name: String,
}

/// The family of candidates for `model`'s motor: its own wells (index 0), then the gaussian and
/// cosine wells of [`GAUSSIAN_WIDTHS_DEG`] and [`REACHES_DEG`], with the pair interaction and
/// with every coil pulling, each at [`STIFFNESS_FRACTIONS`] of the model's single-pair
/// stiffness.
pub fn family(model: &MagnetTorques) -> Vec<Candidate> {
    let mut out = vec![Candidate {
        torques: model.clone(),
        name: "the model's own wells".into(),
    }];
    for fraction in STIFFNESS_FRACTIONS {
        let k = fraction * model.well.stiffness();
        let mut shapes: Vec<(WellShape, String, f64)> = GAUSSIAN_WIDTHS_DEG
            .iter()
            .map(|&w| {
                let width = Degrees(w).to_radians();
                let shape = WellShape::Gaussian {
                    strength_j: k * width.0 * width.0,
                    width,
                };
                (shape, format!("gaussian wells of {w} deg"), w)
            })
            .collect();
        shapes.push((
            WellShape::Cosine { strength_j: k },
            "cosine wells".into(),
            0.0,
        ));
        for interaction in [Interaction::Pairs, Interaction::Coils] {
            for (shape, shape_name, width) in &shapes {
                for &reach in REACHES_DEG.iter().filter(|&&r| r >= *width) {
                    let well = Well::new(shape.clone(), Degrees(reach).to_radians());
                    let pulls = match interaction {
                        Interaction::Pairs => "each coil pulls its pair's magnet",
                        Interaction::Coils => "every coil pulls every magnet in reach",
                    };
                    out.push(Candidate {
                        torques: MagnetTorques {
                            well,
                            interaction,
                            ..model.clone()
                        },
                        name: format!(
                            "{shape_name} reaching {reach} deg, {pulls}, stiffness {:.3} N m/rad",
                            k
                        ),
                    });
                }
            }
        }
    }
    out
}

/// The candidates and how well each has predicted the steps measured so far.
pub struct Identifier {
    candidates: Vec<Candidate>,
    /// Per candidate, its prediction error (rad) of each measured step.
    errors: Vec<Vec<f64>>,
    settles: usize,
}

impl Identifier {
    /// The [`family`] of `model`'s wells, nothing measured yet.
    pub fn new(model: &MagnetTorques) -> Identifier {
        let candidates = family(model);
        Identifier {
            errors: vec![Vec::new(); candidates.len()],
            candidates,
            settles: 0,
        }
    }

    /// Scores every candidate on one more measured step, settled with the model's body and
    /// weighing settle (`motor`'s; its torques are not used).
    pub fn observe(&mut self, motor: &Motor, o: &Observation) {
        if motor.cancel.is_cancelled() {
            return;
        }
        let errors: Vec<f64> = self
            .candidates
            .par_iter()
            .map(|c| {
                let r = settle(&c.torques, &o.active, &o.from, motor.body, motor.weighing());
                r.q.angle_to(&o.to)
            })
            .collect();
        for (e, x) in self.errors.iter_mut().zip(errors) {
            e.push(x);
        }
        self.settles += self.candidates.len();
    }

    /// Candidate `k`'s median prediction error (the upper of the middle two; 0 before any
    /// measurement). A median, not a mean: a step that ends in another basin than predicted
    /// (where the dynamics, not the wells, decide) does not outweigh the steps predicted well.
    pub fn median(&self, k: usize) -> Radians {
        let mut e = self.errors[k].clone();
        e.sort_by(f64::total_cmp);
        Radians(e.get(e.len() / 2).copied().unwrap_or(0.0))
    }

    /// Candidate `k`'s root mean square prediction error (0 before any measurement).
    pub fn rms(&self, k: usize) -> Radians {
        let e = &self.errors[k];
        Radians((e.iter().map(|x| x * x).sum::<f64>() / e.len().max(1) as f64).sqrt())
    }

    /// The candidate that predicted the steps best: the smallest median error, then the
    /// smallest root mean square, then the first.
    pub fn best(&self) -> usize {
        let scores: Vec<(f64, f64)> = (0..self.candidates.len())
            .map(|k| (self.median(k).0, self.rms(k).0))
            .collect();
        (0..scores.len())
            .min_by(|&a, &b| {
                let (sa, sb) = (scores[a], scores[b]);
                sa.0.total_cmp(&sb.0).then(sa.1.total_cmp(&sb.1))
            })
            .unwrap_or(0)
    }

    /// Which candidate to plan with: `None` (the model itself) while the model's median
    /// prediction error is within `trusted`, or no candidate's is under half the model's;
    /// else the best.
    pub fn choice(&self, trusted: Radians) -> Option<usize> {
        let model = self.median(0).0;
        if model <= trusted.0 {
            return None;
        }
        let k = self.best();
        (k != 0 && self.median(k).0 < 0.5 * model).then_some(k)
    }

    pub fn candidate(&self, k: usize) -> &Candidate {
        &self.candidates[k]
    }

    pub fn len(&self) -> usize {
        self.candidates.len()
    }

    pub fn is_empty(&self) -> bool {
        self.candidates.is_empty()
    }

    /// Settles spent so far.
    pub fn settles(&self) -> usize {
        self.settles
    }
}
