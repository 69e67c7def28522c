//! Identification for the closed loop: which wells the motor really has, judged by the steps it
//! was measured to take. Each candidate model of the wells (the model's own first, then a grid
//! of gaussian and cosine wells of several widths, reaches and stiffnesses, with the pair
//! interaction and with every coil pulling) predicts every measured step: the ball at rest
//! where it was measured, the step's set switched on, settled. A prediction is scored under
//! the sensor's known noise: the squared error in units of the noise, capped where a step
//! ends in another basin than predicted (the dynamics, not the wells, decide those), the cap
//! too for a prediction that does not settle (a physics in which nothing holds the ball
//! explains no step). The sums are log-likelihoods: the model steers until a candidate
//! explains the steps clearly better (by [`SWITCH_MARGIN`]), and then that candidate until
//! another is clearly better than it.
//!
//! The grid only starts the fit: while the model is not the best, the best few candidates are
//! refined in their continuous parameters (width, reach, stiffness) by a pattern search on all
//! the steps measured, so that a plant between the grid's points (cosine wells reaching 35
//! degrees) is found as it is. Everything is counted, nothing timed: the same measurements
//! give the same choice on any machine and thread count.

use crate::model::geometry::{Degrees, Orientation, Pair, Radians};
use crate::physics::dynamics::settle;
use crate::physics::torque::{Interaction, MagnetTorques, Well, WellShape};
use crate::planning::commutation::Motor;
use rayon::prelude::*;

/// Widths (degrees) of the grid's gaussian candidates.
pub const GAUSSIAN_WIDTHS_DEG: [f64; 4] = [7.0, 10.0, 14.0, 20.0];
/// Reaches (maximum attraction distances, degrees) of the grid's candidates, 15 to 60 by 5;
/// a gaussian's reach is at least its width (where its pull peaks). The refinement finds the
/// reaches between.
pub const REACHES_DEG: [f64; 10] = [15.0, 20.0, 25.0, 30.0, 35.0, 40.0, 45.0, 50.0, 55.0, 60.0];
/// Stiffnesses of the grid's candidates, as fractions of the model's single-pair stiffness
/// (the equilibria do not depend on it, only which basin a step ends in: the refinement
/// finds it).
pub const STIFFNESS_FRACTIONS: [f64; 1] = [1.0];
/// A measured step costs at most this (a squared error of 3 noise units): a step that ended in
/// another basin than predicted, or a prediction that does not settle.
pub const CAP: f64 = 9.0;
/// A candidate takes over from the one steering when its summed cost is lower by this much (a
/// likelihood ratio of e^4.5, about 90): one step it explains and the other clearly does not,
/// or several steps each explained somewhat better.
pub const SWITCH_MARGIN: f64 = 9.0;
/// The noise unit of the costs is the sensor's noise, but not below this (radians: 0.2
/// degrees): a noiseless sensor still meets the settle's tolerance and the model's small
/// errors.
pub const MIN_SCALE: f64 = 0.2 * std::f64::consts::PI / 180.0;
/// How many candidates are refined after each step (the best of each kind: gaussian or cosine,
/// pairs or every coil), and how many polls each refinement makes at most.
pub const REFINED: usize = 4;
/// The most polls one refinement makes (see [`REFINED`]).
pub const POLLS: usize = 12;
/// The settles all refinements after one step may spend together (counted, so that the same
/// steps give the same fit on any machine): it bounds the time a step's fit takes.
pub const REFINE_BUDGET: usize = 600;
/// A candidate whose summed cost exceeds the best's by more than this is dropped.
pub const UNLIKELY: f64 = 2.0 * CAP;
/// A candidate whose cost averages at most this per step explains the steps as well as the
/// noise allows (the true wells average 1): no refinement is made.
pub const EXPLAINED: f64 = 2.0;
/// At most this many refined candidates are kept (the worst dropped first).
pub const KEPT_REFINED: usize = 24;

/// One measured step: the ball at rest at `from`, `active` switched on, measured at `to`.
#[derive(Debug, Clone, PartialEq)]
pub struct Observation {
    /// The ball's orientation at rest before the step.
    pub from: Orientation,
    /// The pairs switched on (as the model names them).
    pub active: Vec<Pair>,
    /// The orientation measured after the step.
    pub to: Orientation,
}

/// The shape of a candidate's wells.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// Gaussian wells of this width (degrees).
    Gaussian {
        /// The wells' width, degrees.
        width_deg: f64,
    },
    /// Cosine wells: a pair's energy goes as minus the cosine of its angle, its torque as the
    /// sine.
    Cosine,
}

/// A candidate's continuous parameters (the model's own wells have none: they may be of any
/// shape the scenario allows).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WellParams {
    /// The wells' shape.
    pub shape: Shape,
    /// The maximum attraction distance, degrees.
    pub reach_deg: f64,
    /// The single-pair stiffness at alignment, N m/rad.
    pub stiffness: f64,
    /// Which coils pull which magnets.
    pub interaction: Interaction,
}

impl WellParams {
    /// The torques of these wells on `model`'s packings.
    pub fn torques(&self, model: &MagnetTorques) -> MagnetTorques {
        let shape = match self.shape {
            Shape::Gaussian { width_deg } => {
                let w = Degrees(width_deg).to_radians();
                WellShape::Gaussian {
                    strength_j: self.stiffness * w.0 * w.0,
                    width: w,
                }
            }
            Shape::Cosine => WellShape::Cosine {
                strength_j: self.stiffness,
            },
        };
        MagnetTorques {
            well: Well::new(shape, Degrees(self.reach_deg).to_radians()),
            interaction: self.interaction,
            ..model.clone()
        }
    }

    /// In words: "cosine wells reaching 35.0 deg, every coil pulls every magnet in reach,
    /// stiffness 4.000 N m/rad".
    pub fn name(&self) -> String {
        let shape = match self.shape {
            Shape::Gaussian { width_deg } => format!("gaussian wells of {width_deg:.1} deg"),
            Shape::Cosine => "cosine wells".into(),
        };
        let pulls = match self.interaction {
            Interaction::Pairs => "each coil pulls its pair's magnet",
            Interaction::Coils => "every coil pulls every magnet in reach",
        };
        format!(
            "{shape} reaching {:.1} deg, {pulls}, stiffness {:.3} N m/rad",
            self.reach_deg, self.stiffness
        )
    }

    /// Within the bounds a refinement keeps to: widths of 3 to 45 degrees, reaches from the
    /// width (at least 8 degrees) to 75, stiffnesses from 1/16 to 4 times the model's `k`.
    fn within(&self, k: f64) -> bool {
        let width = match self.shape {
            Shape::Gaussian { width_deg } => width_deg,
            Shape::Cosine => 0.0,
        };
        (width == 0.0 || (3.0..=45.0).contains(&width))
            && self.reach_deg >= width.max(8.0)
            && self.reach_deg <= 75.0
            && (k / 16.0..=4.0 * k).contains(&self.stiffness)
    }

    /// The neighbours a poll of the pattern search tries at step level `level` (0 the
    /// coarsest): each parameter up and down.
    fn neighbours(&self, level: usize) -> Vec<WellParams> {
        let f = 0.5f64.powi(level as i32);
        let width = 1.25f64.powf(f);
        let reach = 4.0 * f;
        let stiff = 1.6f64.powf(f);
        let mut out = Vec::new();
        if let Shape::Gaussian { width_deg } = self.shape {
            for w in [width_deg * width, width_deg / width] {
                out.push(WellParams {
                    shape: Shape::Gaussian { width_deg: w },
                    ..*self
                });
            }
        }
        for r in [self.reach_deg + reach, self.reach_deg - reach] {
            out.push(WellParams {
                reach_deg: r,
                ..*self
            });
        }
        for s in [self.stiffness * stiff, self.stiffness / stiff] {
            out.push(WellParams {
                stiffness: s,
                ..*self
            });
        }
        out
    }
}

/// A candidate model of the wells.
#[derive(Debug, Clone)]
pub struct Candidate {
    /// Its torques on the model's packings.
    pub torques: MagnetTorques,
    /// What it is, in words ("cosine wells reaching 40.0 deg, every coil pulls ...").
    pub name: String,
    /// Its parameters (`None`: the model's own wells).
    pub params: Option<WellParams>,
    /// Made by a refinement (not one of the grid's).
    pub refined: bool,
}

impl Candidate {
    fn of(params: WellParams, model: &MagnetTorques, refined: bool) -> Candidate {
        Candidate {
            torques: params.torques(model),
            name: params.name(),
            params: Some(params),
            refined,
        }
    }
}

/// The grid of candidates for `model`'s motor: its own wells (index 0), then the gaussian and
/// cosine wells of [`GAUSSIAN_WIDTHS_DEG`] and [`REACHES_DEG`], with the pair interaction and
/// with every coil pulling, each at [`STIFFNESS_FRACTIONS`] of the model's single-pair
/// stiffness.
pub fn family(model: &MagnetTorques) -> Vec<Candidate> {
    let mut out = vec![Candidate {
        torques: model.clone(),
        name: "the model's own wells".into(),
        params: None,
        refined: false,
    }];
    let k = model.well.stiffness();
    let shapes: Vec<Shape> = GAUSSIAN_WIDTHS_DEG
        .iter()
        .map(|&w| Shape::Gaussian { width_deg: w })
        .chain([Shape::Cosine])
        .collect();
    for fraction in STIFFNESS_FRACTIONS {
        for interaction in [Interaction::Pairs, Interaction::Coils] {
            for &shape in &shapes {
                let width = match shape {
                    Shape::Gaussian { width_deg } => width_deg,
                    Shape::Cosine => 0.0,
                };
                for &reach in REACHES_DEG.iter().filter(|&&r| r >= width) {
                    let p = WellParams {
                        shape,
                        reach_deg: reach,
                        stiffness: fraction * k,
                        interaction,
                    };
                    out.push(Candidate::of(p, model, false));
                }
            }
        }
    }
    out
}

/// The cost of a prediction `predicted` (settled or not) of a step measured at `to`, the
/// noise unit `scale`: see the module's comment.
fn cost(predicted: &Orientation, settled: bool, to: &Orientation, scale: f64) -> (f64, f64) {
    let e = predicted.angle_to(to);
    let c = if settled {
        (e / scale).powi(2).min(CAP)
    } else {
        CAP
    };
    (c, e)
}

/// The cost and the error of `torques`' prediction of the step `o` (settled with `motor`'s body
/// and settle), the noise unit `scale`.
fn predict(torques: &MagnetTorques, o: &Observation, motor: &Motor, scale: f64) -> (f64, f64) {
    let r = settle(torques, &o.active, &o.from, motor.body, motor.settle);
    cost(&r.q, r.settled, &o.to, scale)
}

/// The candidates and how well each has explained the steps measured so far.
pub struct Identifier {
    model: MagnetTorques,
    candidates: Vec<Candidate>,
    /// Per candidate, the cost and the prediction error (rad) of each measured step.
    costs: Vec<Vec<f64>>,
    errors: Vec<Vec<f64>>,
    observations: Vec<Observation>,
    scale: f64,
    /// The candidate steering now (0: the model).
    steer: usize,
    settles: usize,
}

impl Identifier {
    /// The [`family`] of `model`'s wells, nothing measured yet, for a sensor of noise `noise`.
    pub fn new(model: &MagnetTorques, noise: Radians) -> Identifier {
        let candidates = family(model);
        Identifier {
            model: model.clone(),
            costs: vec![Vec::new(); candidates.len()],
            errors: vec![Vec::new(); candidates.len()],
            candidates,
            observations: Vec::new(),
            scale: noise.0.max(MIN_SCALE),
            steer: 0,
            settles: 0,
        }
    }

    /// Scores every candidate on one more measured step, settled with the model's body and
    /// settle (`motor`'s; its torques are not used: a set that holds no strict minimum is
    /// followed to where the ball stops, as the plant does), refines the best while the model
    /// is not the best, and chooses the candidate that steers from now on.
    pub fn observe(&mut self, motor: &Motor, o: &Observation) {
        if motor.cancel.is_cancelled() {
            return;
        }
        let scale = self.scale;
        let scored: Vec<(f64, f64)> = self
            .candidates
            .par_iter()
            .map(|c| predict(&c.torques, o, motor, scale))
            .collect();
        for (k, (c, e)) in scored.into_iter().enumerate() {
            self.costs[k].push(c);
            self.errors[k].push(e);
        }
        self.settles += self.candidates.len();
        self.observations.push(o.clone());
        self.drop_unlikely();
        let best = self.best();
        let explained = self.score(best) <= EXPLAINED * self.observations.len() as f64;
        if best != 0 && !explained {
            self.refine(motor);
        }
        let best = self.best();
        if self.score(best) + SWITCH_MARGIN < self.score(self.steer) {
            self.steer = best;
        }
    }

    /// The summed cost of candidate `k` over the steps measured (a negative log-likelihood, up
    /// to a constant).
    pub fn score(&self, k: usize) -> f64 {
        self.costs[k].iter().sum()
    }

    /// The candidate with the lowest score (the first of equals: the model before any other).
    pub fn best(&self) -> usize {
        (0..self.candidates.len())
            .min_by(|&a, &b| self.score(a).total_cmp(&self.score(b)).then(a.cmp(&b)))
            .unwrap_or(0)
    }

    /// The candidate that steers: `None` while the model does.
    pub fn steer(&self) -> Option<usize> {
        (self.steer != 0).then_some(self.steer)
    }

    /// Candidate `k` no longer steers (its physics gave no way on): the model, or the best of
    /// the others, steers instead, and `k` is dropped from the choice.
    pub fn reject(&mut self, k: usize) {
        if k == 0 {
            return;
        }
        for c in &mut self.costs[k] {
            *c = f64::INFINITY;
        }
        if self.steer == k {
            let best = self.best();
            self.steer = if self.score(best) + SWITCH_MARGIN < self.score(0) {
                best
            } else {
                0
            };
        }
    }

    /// The summed costs of `params` over every step measured, and the prediction errors.
    fn evaluate(&self, motor: &Motor, params: &WellParams) -> (f64, Vec<f64>, Vec<f64>) {
        let torques = params.torques(&self.model);
        let scale = self.scale;
        let scored: Vec<(f64, f64)> = self
            .observations
            .par_iter()
            .map(|o| predict(&torques, o, motor, scale))
            .collect();
        let costs: Vec<f64> = scored.iter().map(|s| s.0).collect();
        let errors = scored.iter().map(|s| s.1).collect();
        (costs.iter().sum(), costs, errors)
    }

    /// Refines the [`REFINED`] best candidates with parameters by a pattern search: from each,
    /// every neighbour is scored on all the steps; the best that improves is taken, else the
    /// steps are halved (twice), for at most [`POLLS`] polls. The ends join the candidates.
    fn refine(&mut self, motor: &Motor) {
        let k = self.model.well.stiffness();
        let mut order: Vec<usize> = (0..self.candidates.len()).collect();
        order.sort_by(|&a, &b| self.score(a).total_cmp(&self.score(b)).then(a.cmp(&b)));
        // the best of each kind (shape and interaction): a local search from the best alone
        // stays with its kind
        let mut starts: Vec<WellParams> = Vec::new();
        for p in order.iter().filter_map(|&i| self.candidates[i].params) {
            let kind = |q: &WellParams| (matches!(q.shape, Shape::Cosine), q.interaction);
            if !starts.iter().any(|s| kind(s) == kind(&p)) {
                starts.push(p);
            }
            if starts.len() == REFINED {
                break;
            }
        }
        let budget = self.settles + REFINE_BUDGET;
        for start in starts {
            if self.settles >= budget {
                break;
            }
            let mut at = start;
            let mut score = self.evaluate(motor, &at).0;
            self.settles += self.observations.len();
            let mut level = 0;
            for _ in 0..POLLS {
                if self.settles >= budget {
                    break;
                }
                let tries: Vec<WellParams> = at
                    .neighbours(level)
                    .into_iter()
                    .filter(|p| p.within(k))
                    .collect();
                // every neighbour's settles at once (each sum is taken in the steps' order, so the
                // scores are those of one neighbour at a time)
                let scored: Vec<f64> = (tries.par_iter())
                    .map(|p| self.evaluate(motor, p).0)
                    .collect();
                self.settles += tries.len() * self.observations.len();
                let best = (0..tries.len())
                    .min_by(|&a, &b| scored[a].total_cmp(&scored[b]).then(a.cmp(&b)));
                match best {
                    Some(b) if scored[b] < score - 1e-9 => {
                        at = tries[b];
                        score = scored[b];
                    }
                    _ if level < 2 => level += 1,
                    _ => break,
                }
            }
            if self.candidates.iter().any(|c| c.params == Some(at)) {
                continue;
            }
            let (_, costs, errors) = self.evaluate(motor, &at);
            self.settles += self.observations.len();
            self.candidates.push(Candidate::of(at, &self.model, true));
            self.costs.push(costs);
            self.errors.push(errors);
        }
        self.prune();
    }

    /// Drops the candidates that explain the steps worse than the best by more than
    /// [`UNLIKELY`] (a likelihood ratio below e^-9: two steps it cannot make that the best
    /// makes), never the model nor the one steering: the grid only starts the fit, and after a
    /// few steps the few that are left are scored on each further step.
    fn drop_unlikely(&mut self) {
        let bound = self.score(self.best()) + UNLIKELY;
        let keep: Vec<bool> = (0..self.candidates.len())
            .map(|k| k == 0 || k == self.steer || self.score(k) <= bound)
            .collect();
        let steer = self.candidates[self.steer].params;
        let mut k = 0;
        self.candidates.retain(|_| (keep[k], k += 1).0);
        let mut k = 0;
        self.costs.retain(|_| (keep[k], k += 1).0);
        let mut k = 0;
        self.errors.retain(|_| (keep[k], k += 1).0);
        self.steer = if self.steer == 0 {
            0
        } else {
            (1..self.candidates.len())
                .find(|&k| self.candidates[k].params == steer)
                .unwrap_or(0)
        };
    }

    /// Keeps at most [`KEPT_REFINED`] refined candidates (after the grid): the worst go first,
    /// never the one steering.
    fn prune(&mut self) {
        let grid = self.candidates.iter().filter(|c| !c.refined).count();
        while self.candidates.len() > grid + KEPT_REFINED {
            let worst = (0..self.candidates.len())
                .filter(|&i| self.candidates[i].refined)
                .filter(|&i| i != self.steer)
                .max_by(|&a, &b| self.score(a).total_cmp(&self.score(b)).then(b.cmp(&a)));
            let Some(w) = worst else { break };
            self.candidates.remove(w);
            self.costs.remove(w);
            self.errors.remove(w);
            if self.steer > w {
                self.steer -= 1;
            }
        }
    }

    /// Candidate `k`'s median prediction error (the upper of the middle two; 0 before any
    /// measurement).
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

    /// Candidate `k` (below [`Identifier::len`]).
    pub fn candidate(&self, k: usize) -> &Candidate {
        &self.candidates[k]
    }

    /// How many candidates are kept.
    pub fn len(&self) -> usize {
        self.candidates.len()
    }

    /// Whether no candidate is kept.
    pub fn is_empty(&self) -> bool {
        self.candidates.is_empty()
    }

    /// Settles spent so far.
    pub fn settles(&self) -> usize {
        self.settles
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    fn torques() -> MagnetTorques {
        let w = Degrees(10.0).to_radians();
        MagnetTorques {
            rotor: vec![Vector3::z(), Vector3::x()],
            stator: vec![-Vector3::z()],
            well: Well::new(
                WellShape::Gaussian {
                    strength_j: 0.25,
                    width: w,
                },
                Degrees(30.0).to_radians(),
            ),
            interaction: Interaction::Pairs,
        }
    }

    #[test]
    fn the_family_has_the_counted_size_and_the_model_first() {
        let t = torques();
        let f = family(&t);
        assert!(f[0].params.is_none());
        let k = t.well.stiffness();
        assert!(f[1..].iter().all(|c| c.params.is_some_and(|p| p.within(k))));
    }

    #[test]
    fn a_parameter_set_makes_the_wells_it_names() {
        let p = WellParams {
            shape: Shape::Gaussian { width_deg: 12.0 },
            reach_deg: 25.0,
            stiffness: 8.0,
            interaction: Interaction::Coils,
        };
        let t = p.torques(&torques());
        assert!((t.well.stiffness() - 8.0).abs() < 1e-12);
        assert!((t.well.max_attraction().0.to_degrees() - 25.0).abs() < 1e-12);
        assert_eq!(t.interaction, Interaction::Coils);
        assert!(p
            .name()
            .starts_with("gaussian wells of 12.0 deg reaching 25.0 deg, every coil"));
    }

    #[test]
    fn a_prediction_costs_its_squared_error_in_noise_units_up_to_the_cap() {
        let a = Orientation::identity();
        let turn = |deg: f64| {
            crate::model::geometry::rot_q(
                &crate::model::geometry::UnitVec::new_normalize(Vector3::x()),
                Degrees(deg).to_radians(),
            )
        };
        let s = 1f64.to_radians();
        assert!((cost(&turn(2.0), true, &a, s).0 - 4.0).abs() < 1e-9);
        assert_eq!(cost(&turn(5.0), true, &a, s).0, CAP);
        // a prediction that does not settle explains nothing, however near it stopped
        assert_eq!(cost(&a, false, &a, s).0, CAP);
    }
}
