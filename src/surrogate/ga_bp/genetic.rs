//! A real-coded genetic algorithm (he2019 §3.3, Fig. 11a): it evolves the
//! network's weights and thresholds before back-propagation refines them.
//!
//! Each generation: the `elites` fittest genomes pass unchanged (so the best
//! fitness never gets worse); every other child comes from two parents chosen
//! by tournament (the fittest of `tournament` genomes drawn with replacement),
//! recombined with probability `crossover_rate` by extended intermediate
//! recombination (child gene = p₁ + α (p₂ − p₁), α uniform in [−0.25, 1.25]
//! per gene; Mühlenbein & Schlierkamp-Voosen 1993) and otherwise a copy of
//! the first parent, then mutated gene by gene with probability
//! `mutation_rate` by a uniform offset in [−`mutation_step`, `mutation_step`].
//! Initial genes are uniform in [−`initial_range`, `initial_range`].
//!
//! he2019 gives no population size, rates or generation count; the defaults
//! ([`GaSettings::default`]) are ours and are recorded with every model.
//! Randomness comes only from the ChaCha stream handed in; fitness ties are
//! broken by index, so a run is a pure function of its seed.

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Settings of [`evolve`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GaSettings {
    /// Genomes per generation (≥ 2).
    pub population: usize,
    /// Generations after the initial one.
    pub generations: usize,
    /// Genomes drawn per tournament (≥ 1).
    pub tournament: usize,
    /// Probability that a child is recombined from two parents, in [0, 1].
    pub crossover_rate: f64,
    /// Probability that each gene of a child is mutated, in [0, 1].
    pub mutation_rate: f64,
    /// Half-width of a mutation's uniform offset.
    pub mutation_step: f64,
    /// Genomes copied unchanged into the next generation (< population).
    pub elites: usize,
    /// Half-width of the uniform initial genes.
    pub initial_range: f64,
}

impl Default for GaSettings {
    fn default() -> Self {
        GaSettings {
            population: 40,
            generations: 60,
            tournament: 3,
            crossover_rate: 0.8,
            mutation_rate: 0.1,
            mutation_step: 0.5,
            elites: 2,
            initial_range: 1.0,
        }
    }
}

impl GaSettings {
    /// What is wrong with these settings, if anything.
    pub fn check(&self) -> Result<(), String> {
        let unit = |v: f64| (0.0..=1.0).contains(&v);
        if self.population < 2 {
            return Err(format!("population = {}: must be >= 2", self.population));
        }
        if self.tournament < 1 {
            return Err(format!("tournament = {}: must be >= 1", self.tournament));
        }
        if self.elites >= self.population {
            return Err(format!(
                "elites = {}: must be < population = {}",
                self.elites, self.population
            ));
        }
        if !unit(self.crossover_rate) || !unit(self.mutation_rate) {
            return Err(format!(
                "crossover_rate = {}, mutation_rate = {}: must be in [0, 1]",
                self.crossover_rate, self.mutation_rate
            ));
        }
        let step_ok = self.mutation_step.is_finite() && self.mutation_step >= 0.0;
        let range_ok = self.initial_range.is_finite() && self.initial_range > 0.0;
        if !step_ok || !range_ok {
            return Err(format!(
                "mutation_step = {}, initial_range = {}: must be finite, >= 0 and > 0",
                self.mutation_step, self.initial_range
            ));
        }
        Ok(())
    }
}

/// What [`evolve`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct GaOutcome {
    /// The fittest genome of the last generation.
    pub best: Vec<f64>,
    /// Its fitness.
    pub best_fitness: f64,
    /// Best fitness of every generation, the initial one first.
    pub history: Vec<f64>,
}

/// Minimises `fitness` over genomes of length `genes` (settings checked by
/// the caller with [`GaSettings::check`]).
pub fn evolve(
    genes: usize,
    fitness: impl Fn(&[f64]) -> f64,
    settings: &GaSettings,
    rng: &mut ChaCha8Rng,
) -> GaOutcome {
    let r = settings.initial_range;
    let mut population: Vec<Vec<f64>> = (0..settings.population)
        .map(|_| (0..genes).map(|_| rng.random_range(-r..=r)).collect())
        .collect();
    let mut scores: Vec<f64> = population.iter().map(|g| fitness(g)).collect();
    let mut history = Vec::with_capacity(settings.generations + 1);
    let mut order = ranking(&scores);
    history.push(scores[order[0]]);
    for _ in 0..settings.generations {
        let mut next: Vec<Vec<f64>> = order[..settings.elites]
            .iter()
            .map(|&i| population[i].clone())
            .collect();
        while next.len() < settings.population {
            let a = tournament(&scores, settings.tournament, rng);
            let b = tournament(&scores, settings.tournament, rng);
            let mut child = if rng.random::<f64>() < settings.crossover_rate {
                recombine(&population[a], &population[b], rng)
            } else {
                population[a].clone()
            };
            mutate(&mut child, settings, rng);
            next.push(child);
        }
        population = next;
        scores = population.iter().map(|g| fitness(g)).collect();
        order = ranking(&scores);
        history.push(scores[order[0]]);
    }
    let best = order[0];
    GaOutcome {
        best: population[best].clone(),
        best_fitness: scores[best],
        history,
    }
}

/// Indices sorted by fitness, ties (and NaN, ranked last) broken by index.
fn ranking(scores: &[f64]) -> Vec<usize> {
    let key = |i: usize| {
        if scores[i].is_nan() {
            f64::INFINITY
        } else {
            scores[i]
        }
    };
    let mut order: Vec<usize> = (0..scores.len()).collect();
    order.sort_by(|&a, &b| key(a).total_cmp(&key(b)).then(a.cmp(&b)));
    order
}

/// The fittest of `size` genomes drawn with replacement.
fn tournament(scores: &[f64], size: usize, rng: &mut ChaCha8Rng) -> usize {
    let mut best = rng.random_range(0..scores.len());
    for _ in 1..size {
        let other = rng.random_range(0..scores.len());
        if scores[other] < scores[best] || (scores[other] == scores[best] && other < best) {
            best = other;
        }
    }
    best
}

/// Extended intermediate recombination: α uniform in [−0.25, 1.25] per gene.
fn recombine(a: &[f64], b: &[f64], rng: &mut ChaCha8Rng) -> Vec<f64> {
    a.iter()
        .zip(b)
        .map(|(x, y)| x + rng.random_range(-0.25..=1.25) * (y - x))
        .collect()
}

fn mutate(genome: &mut [f64], settings: &GaSettings, rng: &mut ChaCha8Rng) {
    let s = settings.mutation_step;
    for gene in genome {
        if rng.random::<f64>() < settings.mutation_rate {
            *gene += rng.random_range(-s..=s);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn sphere(g: &[f64]) -> f64 {
        g.iter().map(|x| (x - 0.3).powi(2)).sum()
    }

    #[test]
    fn with_elitism_the_best_fitness_never_gets_worse_and_improves() {
        let settings = GaSettings::default();
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let out = evolve(6, sphere, &settings, &mut rng);
        assert_eq!(out.history.len(), settings.generations + 1);
        for w in out.history.windows(2) {
            assert!(w[1] <= w[0], "best fitness rose: {:?}", out.history);
        }
        // The initial best of 40 uniform genomes in [−1, 1]⁶ is ~1; sixty
        // generations must shrink it by well over an order of magnitude.
        assert!(
            out.best_fitness < out.history[0] / 10.0,
            "{:?}",
            out.history
        );
        assert_eq!(out.best_fitness, sphere(&out.best));
    }

    #[test]
    fn the_same_seed_gives_the_same_result() {
        let settings = GaSettings::default();
        let run = |seed| evolve(4, sphere, &settings, &mut ChaCha8Rng::seed_from_u64(seed));
        assert_eq!(run(5), run(5));
        assert_ne!(run(5).best, run(6).best);
    }

    #[test]
    fn bad_settings_are_named() {
        let mut s = GaSettings::default();
        s.elites = s.population;
        assert!(s.check().unwrap_err().contains("elites = 40"));
    }
}
