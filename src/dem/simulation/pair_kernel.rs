//! The pair kernel: packed per-particle records and the evaluation of listed
//! pairs four contacts at a time.

use super::worse;
use crate::dem::contact::{
    evaluate_lanes, ContactHistory, GeometryLanes, MotionLanes, NormalModel, PairCoefficients,
    RollingModel,
};
use crate::dem::domain::Domain;
use crate::dem::effects::Boundary;
use crate::dem::lanes::{F64x4, Real, Vec3L, MAX_LANES};
use crate::dem::vec3::Vec3;

/// What the pair kernel reads first of a particle, packed in one 32-byte
/// record: centre (m) and radius (m). Enough to reject a listed pair that does
/// not touch.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
pub(super) struct Sphere {
    pub(super) x: Vec3,
    pub(super) r: f64,
}

/// What the contact laws read of a touching particle, packed in one 64-byte
/// record: the full-step velocity estimates v½ + ½dt·F/m (m/s) and
/// ω½ + ½dt·T/I (rad/s) (see the stepper's `Drift`), the mass (kg) and
/// the inverse radius (1/m, for overlap ratios).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
pub(super) struct Motion {
    pub(super) v: Vec3,
    pub(super) w: Vec3,
    pub(super) m: f64,
    pub(super) inv_r: f64,
}

/// Per-particle factors that depend only on mass and radius, computed when
/// particles are added or removed instead of every step (each is the same
/// expression the kick would evaluate, so results do not change): the
/// half-kick factors ½dt/m (s/kg) and ½dt/I (s/(kg·m²), I = 0.4 m r²).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Kick {
    pub(super) v: f64,
    pub(super) w: f64,
}

impl Kick {
    pub(super) fn new(dt: f64, m: f64, r: f64) -> Self {
        Self {
            v: 0.5 * dt / m,
            w: 0.5 * dt / (0.4 * m * r * r),
        }
    }
}

/// The force a pair exerts, handed to a [`PairSink`].
#[derive(Clone, Copy, Debug)]
pub(super) struct PairForce {
    pub(super) force_on_first: Vec3,
    /// Torque on the first and on the second particle, N·m.
    pub(super) torque: [Vec3; 2],
}

/// Where the pair kernel puts each listed pair's result.
pub(super) trait PairSink {
    /// The pair of particles `i < j` carries `force` (pairs out of contact
    /// are not handed over).
    fn put(&mut self, i: usize, j: usize, force: &PairForce);
}

/// What the pair kernel found over a run of pairs (reductions exact and
/// order-independent, so merging per-tile findings in any order gives the
/// same result).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct PairFound {
    /// Force-carrying contacts.
    pub(super) contacts: usize,
    /// Worst (overlap ratio, pair index).
    pub(super) worst: (f64, usize),
    /// Largest relative normal approach speed of a force-carrying contact,
    /// m/s (0 if none approaches).
    pub(super) approach_m_s: f64,
}

impl Default for PairFound {
    fn default() -> Self {
        Self {
            contacts: 0,
            worst: (0.0, usize::MAX),
            approach_m_s: 0.0,
        }
    }
}

impl PairFound {
    /// Both findings together.
    pub(super) fn merge(self, o: Self) -> Self {
        Self {
            contacts: self.contacts + o.contacts,
            worst: worse(self.worst, o.worst),
            approach_m_s: self.approach_m_s.max(o.approach_m_s),
        }
    }
}

/// Contacts evaluated side by side in the pair kernel (one AVX2 register of
/// f64, two SSE2 registers).
pub(super) const PAIR_LANES: usize = 4;

/// What the pair kernel reads, borrowed for one force evaluation.
pub(super) struct PairKernel<'a, B: Boundary> {
    pub(super) spheres: &'a [Sphere],
    pub(super) motion: &'a [Motion],
    pub(super) domain: Domain,
    pub(super) coef: PairCoefficients,
    /// Extra contact range, m (JKR only).
    pub(super) reach: f64,
    pub(super) dt: f64,
    pub(super) _boundary: std::marker::PhantomData<B>,
}

impl<B: Boundary> PairKernel<'_, B> {
    /// Evaluates a run of listed pairs whose first pair has index `first`,
    /// handing each pair's forces to `sink` in pair order, four at a time and a
    /// short tail one at a time; returns the force-carrying contacts, the
    /// worst (overlap ratio, pair index) and the fastest approach. Runs the AVX-512 copy of the loop
    /// where the processor has it.
    pub(super) fn run<N: NormalModel, R: RollingModel, S: PairSink>(
        &self,
        first: usize,
        pairs: &[[u32; 2]],
        history: &mut [ContactHistory<N, R>],
        sink: &mut S,
    ) -> PairFound {
        #[cfg(target_arch = "x86_64")]
        if crate::dem::lanes::has_avx512() {
            // SAFETY: `has_avx512` found every feature `run_avx512` enables.
            return unsafe { self.run_avx512(first, pairs, history, sink) };
        }
        self.run_inline(first, pairs, history, sink)
    }

    /// [`run`](Self::run) compiled for AVX-512 (see [`has_avx512`](crate::dem::lanes::has_avx512)): the
    /// whole loop, contact laws and sink included, is inlined here so that
    /// all of it gets the 32 registers, which makes it faster than the
    /// portable copy. It too takes four contacts at a time: eight (two
    /// four-lane halves) were slower.
    ///
    /// Measured: docs/performance.md ("src/dem/simulation/pair_kernel.rs").
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512vl,avx512dq,avx512bw,avx512cd")]
    fn run_avx512<N: NormalModel, R: RollingModel, S: PairSink>(
        &self,
        first: usize,
        pairs: &[[u32; 2]],
        history: &mut [ContactHistory<N, R>],
        sink: &mut S,
    ) -> PairFound {
        self.run_inline(first, pairs, history, sink)
    }

    /// The body of [`run`](Self::run), inlined into each instruction-set copy.
    #[inline(always)]
    fn run_inline<N: NormalModel, R: RollingModel, S: PairSink>(
        &self,
        first: usize,
        pairs: &[[u32; 2]],
        history: &mut [ContactHistory<N, R>],
        sink: &mut S,
    ) -> PairFound {
        let whole = pairs.len() / PAIR_LANES * PAIR_LANES;
        let (history, history_tail) = history.split_at_mut(whole);
        let a = self.run_lanes::<N, R, F64x4, S>(first, &pairs[..whole], history, sink);
        let b = self.run_lanes::<N, R, f64, S>(first + whole, &pairs[whole..], history_tail, sink);
        a.merge(b)
    }

    /// [`run`](Self::run) for a number of pairs that `T::LANES` divides.
    #[inline(always)]
    fn run_lanes<N: NormalModel, R: RollingModel, T: Real, S: PairSink>(
        &self,
        first: usize,
        pairs: &[[u32; 2]],
        history: &mut [ContactHistory<N, R>],
        sink: &mut S,
    ) -> PairFound {
        let mut acc = PairFound::default();
        // The fastest approach per lane, reduced across lanes once at the end.
        let mut fastest = T::splat(0.0);
        for (k, (p, h)) in pairs
            .chunks_exact(T::LANES)
            .zip(history.chunks_exact_mut(T::LANES))
            .enumerate()
        {
            let (found, approach) = self.lanes::<N, R, T, S>(first + k * T::LANES, p, h, sink);
            acc = acc.merge(found);
            fastest = T::select(approach.gt(fastest), approach, fastest);
        }
        acc.approach_m_s = (0..T::LANES).map(|l| fastest.lane(l)).fold(0.0, f64::max);
        acc
    }

    /// `T::LANES` listed pairs with indices `first..` at once (each slice
    /// holds one entry per lane); returns what they found (but the approach)
    /// and each lane's approach speed (0 where not in contact), m/s.
    #[inline(always)]
    fn lanes<N: NormalModel, R: RollingModel, T: Real, S: PairSink>(
        &self,
        first: usize,
        pairs: &[[u32; 2]],
        history: &mut [ContactHistory<N, R>],
        sink: &mut S,
    ) -> (PairFound, T) {
        let at = |l: usize| pairs[l.min(T::LANES - 1)].map(|k| k as usize);
        let si: [&Sphere; MAX_LANES] = std::array::from_fn(|l| &self.spheres[at(l)[0]]);
        let sj: [&Sphere; MAX_LANES] = std::array::from_fn(|l| &self.spheres[at(l)[1]]);
        let mi: [&Motion; MAX_LANES] = std::array::from_fn(|l| &self.motion[at(l)[0]]);
        let mj: [&Motion; MAX_LANES] = std::array::from_fn(|l| &self.motion[at(l)[1]]);
        let d = B::separation_lanes(
            &self.domain,
            Vec3L::<T>::from_fn(|l| si[l].x) - Vec3L::from_fn(|l| sj[l].x),
        );
        let dist_sq = d.norm_squared();
        let (ri, rj) = (T::from_fn(|l| si[l].r), T::from_fn(|l| sj[l].r));
        let touch = ri + rj;
        let limit = touch + T::splat(self.reach);
        let in_range = T::not(dist_sq.ge(limit * limit));
        let dist = dist_sq.sqrt();
        let n = d.scale(T::splat(1.0) / dist);
        let overlap = touch - dist;
        let half = T::splat(0.5);
        let arm_i = ri - half * overlap;
        let arm_j = rj - half * overlap;
        let (wi, wj) = (
            Vec3L::<T>::from_fn(|l| mi[l].w),
            Vec3L::<T>::from_fn(|l| mj[l].w),
        );
        let motion = MotionLanes {
            velocity: Vec3L::from_fn(|l| mi[l].v)
                - Vec3L::from_fn(|l| mj[l].v)
                - (wi.scale(arm_i) + wj.scale(arm_j)).cross(&n),
            angular_velocity: wi - wj,
        };
        // `harmonic` of two finite values, lane-wise: particles are never rigid.
        let (m_i, m_j) = (T::from_fn(|l| mi[l].m), T::from_fn(|l| mj[l].m));
        let geometry = GeometryLanes {
            normal: n,
            overlap_m: overlap,
            r_star_m: ri * rj / (ri + rj),
            m_star_kg: m_i * m_j / (m_i + m_j),
        };
        let c =
            evaluate_lanes::<N, R, T>(&self.coef, &geometry, &motion, in_range, self.dt, history);
        let lever = n.cross(&c.tangential_force);
        let torque_i = c.rolling_torque - lever.scale(arm_i);
        let torque_j = -c.rolling_torque - lever.scale(arm_j);
        let mut found = PairFound::default();
        for l in 0..T::LANES {
            let [i, j] = at(l);
            if T::flag(c.active, l) {
                let ratio = overlap.lane(l).max(0.0) * mi[l].inv_r.max(mj[l].inv_r);
                found.contacts += 1;
                found.worst = worse(found.worst, (ratio, first + l));
                let force = PairForce {
                    force_on_first: c.force.lane(l),
                    torque: [torque_i.lane(l), torque_j.lane(l)],
                };
                sink.put(i, j, &force);
            }
        }
        let approach = T::select(c.active, -c.normal_velocity_m_s, T::splat(0.0));
        (found, approach)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dem::contact::normal_hertz::Hertz;
    use crate::dem::contact::normal_jkr::Jkr;
    use crate::dem::contact::rolling_cdt::ConstantDirectionalTorque;
    use crate::dem::contact::rolling_epsd::ElasticPlasticSpring;
    use crate::dem::contact::test_support::coefficients;
    use crate::dem::effects::Periodic;
    use rand::{Rng, SeedableRng};

    /// Every pair the kernel hands over, in order, as bits: (i, j, force
    /// and torques).
    #[derive(Default, PartialEq, Debug)]
    struct Recorder(Vec<(usize, usize, [u64; 9])>);

    impl PairSink for Recorder {
        fn put(&mut self, i: usize, j: usize, f: &PairForce) {
            let v = [f.force_on_first, f.torque[0], f.torque[1]];
            let bits = std::array::from_fn(|k| v[k / 3][k % 3].to_bits());
            self.0.push((i, j, bits));
        }
    }

    /// The dispatching `run` (the AVX-512 copy where this processor has it)
    /// against the portable body, on a jittered 4×4×4 lattice of 1 mm spheres
    /// 1.9 mm apart in a periodic box (so pairs touch, barely touch, and lie
    /// apart across the boundary), for three steps so that histories build
    /// up: forces, torques, counts and histories must agree bit for bit.
    fn dispatch_matches_portable<N: NormalModel, R: RollingModel>() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(20261126);
        let mut jitter = |s: f64| s * (2.0 * rng.random::<f64>() - 1.0);
        let side = 4;
        let spacing = 1.9e-3;
        let count = side * side * side;
        let spheres: Vec<Sphere> = (0..count)
            .map(|k| Sphere {
                x: Vec3::new(
                    (k % side) as f64 * spacing + jitter(2e-4),
                    (k / side % side) as f64 * spacing + jitter(2e-4),
                    (k / side / side) as f64 * spacing + jitter(2e-4),
                ),
                r: 1e-3 * (1.0 + jitter(0.05)),
            })
            .collect();
        let motion: Vec<Motion> = spheres
            .iter()
            .map(|s| Motion {
                v: Vec3::new(jitter(0.1), jitter(0.1), jitter(0.1)),
                w: Vec3::new(jitter(50.0), jitter(50.0), jitter(50.0)),
                m: 2500.0 * 4.0 / 3.0 * std::f64::consts::PI * s.r.powi(3),
                inv_r: 1.0 / s.r,
            })
            .collect();
        let pairs: Vec<[u32; 2]> = (0..count as u32)
            .flat_map(|i| (i + 1..count as u32).map(move |j| [i, j]))
            .collect();
        let box_side = side as f64 * spacing;
        let domain = Domain::new(
            Vec3::repeat(-0.5 * spacing),
            Vec3::repeat(box_side - 0.5 * spacing),
            [true; 3],
        )
        .unwrap();
        let coef = coefficients(0.3, 0.4, 0.2, if N::ADHESIVE { 0.05 } else { 0.0 });
        let kernel = PairKernel::<Periodic> {
            spheres: &spheres,
            motion: &motion,
            domain,
            coef,
            reach: N::reach_m(&coef, 1e-3),
            dt: 1e-5,
            _boundary: std::marker::PhantomData,
        };
        let mut portable = vec![ContactHistory::<N, R>::default(); pairs.len()];
        let mut dispatched = portable.clone();
        let mut touching = 0;
        for _ in 0..3 {
            let (mut a, mut b) = (Recorder::default(), Recorder::default());
            let found_a = kernel.run_inline(0, &pairs, &mut portable, &mut a);
            let found_b = kernel.run(0, &pairs, &mut dispatched, &mut b);
            assert_eq!(found_a.contacts, found_b.contacts);
            assert_eq!(found_a.worst.0.to_bits(), found_b.worst.0.to_bits());
            assert_eq!(found_a.worst.1, found_b.worst.1);
            assert_eq!(
                found_a.approach_m_s.to_bits(),
                found_b.approach_m_s.to_bits()
            );
            assert_eq!(a, b);
            // Debug prints each f64 so that it round-trips: equal text, equal bits.
            let text = |h: &[ContactHistory<N, R>]| -> Vec<String> {
                h.iter()
                    .map(|h| format!("{:?} {:?} {:?}", h.normal, h.tangential, h.rolling))
                    .collect()
            };
            assert_eq!(text(&portable), text(&dispatched));
            touching = found_a.contacts;
        }
        assert!(
            touching > 50 && touching < pairs.len() / 4,
            "{touching} of {} pairs touch",
            pairs.len()
        );
    }

    #[test]
    fn the_dispatched_kernel_is_bit_identical_to_the_portable_one() {
        if !crate::dem::lanes::has_avx512() {
            eprintln!("no AVX-512 here: the dispatched kernel is the portable one");
        }
        dispatch_matches_portable::<Hertz, ConstantDirectionalTorque>();
        dispatch_matches_portable::<Jkr, ElasticPlasticSpring>();
    }
}
