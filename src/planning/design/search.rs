//! The design search's evolution, NSGA-II from the `moors` crate's parts: its binary
//! tournament on rank and crowding (`RankAndScoringSelection`), simulated binary crossover,
//! Gaussian mutation and the rank-and-crowding survival (`Nsga2RankCrowdingSurvival`), driven
//! one generation at a time by the caller (who evaluates each generation's layouts in
//! between, as a batch that may be sharded and resumed). Every random draw comes from one
//! seeded generator in a fixed order, so a seed and the same evaluations give the same
//! generations on any machine and thread count; a run resumed replays the draws.

use moors::genetic::PopulationMOO;
use moors::operators::{
    CrossoverOperator, GaussianMutation, MutationOperator, Nsga2RankCrowdingSurvival,
    SelectionOperator, SimulatedBinaryCrossover, SurvivalOperator,
};
use moors::selection::moo::RankAndScoringSelection;
use moors::{MOORandomGenerator, RandomGenerator};
use ndarray::{Array1, Array2};

/// One layout of a generation: its name, genes and (coarse) objectives.
#[derive(Debug, Clone, PartialEq)]
pub struct Member {
    /// Its name (`gGGG-KKK`: the generation it was born in and its index there).
    pub id: String,
    /// Its genes, each within its bounds.
    pub genes: Vec<f64>,
    /// Its objectives on the coarse axes.
    pub objectives: Vec<f64>,
}

/// The evolution's state: the seeded generator and the operators' settings.
pub struct Evolution {
    rng: MOORandomGenerator,
    bounds: Vec<(f64, f64)>,
}

/// SBX's distribution index (larger: children nearer their parents).
const SBX_ETA: f64 = 15.0;
/// The chance a pair of parents is crossed (else the children are copies).
const CROSSOVER_RATE: f64 = 0.9;
/// Mutation's per-gene chance and its standard deviation (genes span [-1, 1] or [0, 1]).
const MUTATION: (f64, f64) = (0.1, 0.15);

impl Evolution {
    /// A new evolution of genes within `bounds`, its draws from `seed`.
    pub fn new(seed: u64, bounds: Vec<(f64, f64)>) -> Evolution {
        Evolution {
            rng: MOORandomGenerator::new_from_seed(Some(seed)),
            bounds,
        }
    }

    /// `count` genes drawn uniformly within the bounds (the first generation's rest).
    pub fn random_genes(&mut self, count: usize) -> Vec<Vec<f64>> {
        (0..count)
            .map(|_| {
                self.bounds
                    .clone()
                    .iter()
                    .map(|&(lo, hi)| self.rng.gen_range_f64(lo, hi))
                    .collect()
            })
            .collect()
    }

    /// The children of `parents` (ranked by [`Evolution::survivors`]): `count` genes, by
    /// tournament, crossover and mutation, clipped to the bounds.
    pub fn offspring(&mut self, parents: &Ranked, count: usize) -> Vec<Vec<f64>> {
        let pairs = count.div_ceil(2);
        let selection = RankAndScoringSelection::default();
        let (a, b) = selection.operate(&parents.population, pairs, &mut self.rng);
        let sbx = SimulatedBinaryCrossover::new(SBX_ETA);
        let mutation = GaussianMutation::new(MUTATION.0, MUTATION.1);
        let mut out = Vec::with_capacity(2 * pairs);
        for k in 0..pairs {
            let (pa, pb) = (a.genes.row(k).to_owned(), b.genes.row(k).to_owned());
            let (mut c1, mut c2) = if self.rng.gen_bool(CROSSOVER_RATE) {
                sbx.crossover(&pa, &pb, &mut self.rng)
            } else {
                (pa, pb)
            };
            for c in [&mut c1, &mut c2] {
                mutation.mutate(c.view_mut(), &mut self.rng);
                out.push(self.clipped(c));
            }
        }
        out.truncate(count);
        out
    }

    fn clipped(&self, c: &Array1<f64>) -> Vec<f64> {
        c.iter()
            .zip(&self.bounds)
            .map(|(g, &(lo, hi))| g.clamp(lo, hi))
            .collect()
    }

    /// The `count` members of `pool` that survive (rank, then crowding), ranked for the next
    /// tournament; `pool`'s order breaks ties.
    pub fn survivors(&mut self, pool: Vec<Member>, count: usize) -> Ranked {
        let population = population(&pool);
        let kept = Nsga2RankCrowdingSurvival::new().operate(population, count, &mut self.rng);
        let mut taken = vec![false; pool.len()];
        let members = (0..kept.len())
            .map(|r| {
                let row = kept.genes.row(r);
                let k = (0..pool.len())
                    .find(|&k| !taken[k] && pool[k].genes.iter().eq(row.iter()))
                    .unwrap_or(0);
                taken[k] = true;
                pool[k].clone()
            })
            .collect();
        Ranked {
            population: kept,
            members,
        }
    }
}

/// A generation after survival: its members and moors' population with their ranks and
/// crowding distances, in the same order.
pub struct Ranked {
    population: PopulationMOO,
    /// The members, in the population's order.
    pub members: Vec<Member>,
}

impl Ranked {
    /// Each member's rank (0: the first non-dominated front).
    pub fn ranks(&self) -> Vec<usize> {
        match &self.population.rank {
            Some(r) => r.to_vec(),
            None => vec![0; self.members.len()],
        }
    }
}

/// The members as moors' population (genes and objectives, no constraints).
fn population(pool: &[Member]) -> PopulationMOO {
    let genes = pool.first().map_or(0, |m| m.genes.len());
    let objectives = pool.first().map_or(0, |m| m.objectives.len());
    let g = Array2::from_shape_fn((pool.len(), genes), |(i, j)| pool[i].genes[j]);
    let f = Array2::from_shape_fn((pool.len(), objectives), |(i, j)| pool[i].objectives[j]);
    PopulationMOO::new_unconstrained(g, f)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two objectives, x^2 and (x - 2)^2 of the first gene: the front is x in [0, 2].
    fn members(genes: Vec<Vec<f64>>, generation: usize) -> Vec<Member> {
        genes
            .into_iter()
            .enumerate()
            .map(|(k, g)| Member {
                id: format!("g{generation:03}-{k:03}"),
                objectives: vec![g[0] * g[0], (g[0] - 2.0) * (g[0] - 2.0)],
                genes: g,
            })
            .collect()
    }

    fn run(seed: u64) -> Vec<Member> {
        let mut evo = Evolution::new(seed, vec![(-5.0, 5.0), (-1.0, 1.0)]);
        let first = evo.random_genes(12);
        let mut ranked = evo.survivors(members(first, 0), 12);
        for generation in 1..=15 {
            let kids = members(evo.offspring(&ranked, 12), generation);
            let mut pool = ranked.members.clone();
            pool.extend(kids);
            ranked = evo.survivors(pool, 12);
        }
        ranked.members
    }

    #[test]
    fn the_search_converges_on_the_front_and_repeats_itself() {
        let a = run(7);
        assert_eq!(a, run(7), "a seed gives the same generations");
        assert_ne!(a, run(8));
        assert!(
            a.iter().all(|m| (-0.05..=2.05).contains(&m.genes[0])),
            "{:?}",
            a.iter().map(|m| m.genes[0]).collect::<Vec<_>>()
        );
    }
}
