//! The engine throughput benchmark (`repose bench`): builds the dense-bed test
//! bed of `../shared/bench` (the LIGGGHTS and LAMMPS decks) and times it.
//!
//! # The bed
//!
//! Spheres R = 1 mm, ρ = 2500 kg/m³, E = 5 MPa, ν = 0.3, e = 0.5, μ = 0.5, CDT
//! rolling friction 0.1, gravity 9.81 m/s², dt = 2.4477e-5 s (0.2 × the Rayleigh
//! time), skin 0.2 mm, periodic in x and y (period n × 2.4 mm) on a flat wall at
//! z = 0 of the particles' own material. N = n·n·20 spheres start on a
//! simple-cubic lattice of spacing 2.4 mm (the deck's `lattice sc 0.0024 origin
//! 0.5 0.5 0.5`, layers 2 to 21) jittered by up to ±0.2 mm per axis (seeded
//! ChaCha8), and settle under gravity for as many steps as the deck (20,000;
//! 16,000 for n ≥ 50) with the deck's physics (Hertz + CDT). The settled bed is
//! kept in memory; every requested variant (normal model × rolling model ×
//! thread count) starts a fresh simulation from it (contact history starts
//! empty, as after a LIGGGHTS restart) and runs a warm-up (500 steps). Then
//! the timed segments (6,000 / 2,000 / 1,000 steps for n = 16 / 32 / 50, the
//! deck's `nb`) run in rounds: round k runs segment k of every variant, one
//! after the other, so that a change in the machine's speed (other tenants
//! of a shared host) hits every variant alike instead of whichever ran
//! last. Throughput is N × steps / wall seconds of a segment; a variant's
//! speedup is the median over the rounds of its throughput over that of the
//! same kernel on the fewest threads in the same round.
//!
//! # Measured
//!
//! Side by side with LIGGGHTS 3.8.0 (Debian package `liggghts`, serial, the
//! decks of `../shared/bench/liggghts`, settled restart, one LIGGGHTS run
//! before and one after each repose run, same window), on the shared 2-vCPU
//! AMD EPYC builder, 2026-11-21 12:24–12:42. Load average 2.9–3.7 throughout:
//! other builds kept about one core busy, so LIGGGHTS ran at 3.2–4.2 Mps/s here
//! against 4.6–6.1 in `../shared/bench/README.md`, and **a second repose thread
//! got no second core** (the process used ≈ 1.0 CPU-second per second on 2
//! threads: its CPU-time throughput equals its wall throughput), so the
//! 2-thread column measures oversubscription, not scaling. Mps/s = million
//! particle-steps per second, median of 3 timed segments; "cpu" = per
//! CPU-second of the process (repose: `/proc/self/stat`; LIGGGHTS: the
//! decks' `cpu_ticks.sh`).
//!
//! | N      | repose 1 thr (cpu) | repose 2 thr (cpu) | LIGGGHTS (cpu)          | ratio 1 thr, wall (cpu) |
//! |--------|--------------------|--------------------|-------------------------|-------------------------|
//! | 5,120  | 4.69 (5.12)        | 5.33 (5.43)        | 3.88 / 4.24 (4.19/4.57) | 1.16 (1.17)             |
//! | 20,480 | 3.84 (4.07)        | 4.58 (4.61)        | 3.51 / 3.77 (3.85/3.78) | 1.05 (1.07)             |
//! | 50,000 | 3.84 (3.86)        | 3.80 (3.82)        | 3.21 / 3.21 (3.23/3.23) | 1.20 (1.20)             |
//!
//! Settled bed (end of the timed part): 2.27–2.28 force-carrying pairs per
//! particle (4.53–4.57 contacts per particle; LIGGGHTS `c_zmean` 4.52), 0.051
//! wall contacts per particle, 3.4 listed pairs per particle. Rebuilds: every
//! 160–300 steps (LIGGGHTS: every ~400). Settling (2 threads, untimed): 18 s,
//! 92 s, 160 s.
//!
//! Cost of each effect, N = 5,120, 1 thread, same settled bed (rebuild
//! counts differ because the bed moves differently under each law):
//!
//! | kernel                         | Mps/s (cpu)  | relative | LIGGGHTS      |
//! |--------------------------------|--------------|----------|---------------|
//! | hertz + no rolling             | 5.91 (5.95)  | 1.00     | `off`: 4.48   |
//! | hertz + CDT (the deck)         | 5.10 (5.23)  | 0.86     | `cdt`: 4.33   |
//! | hertz + EPSD                   | 4.91 (5.32)  | 0.83     | (1)           |
//! | JKR kernel + no rolling        | 3.14 (3.18)  | 0.53     |               |
//! | JKR kernel + CDT               | 3.05 (3.05)  | 0.52     |               |
//! | JKR kernel + EPSD              | 3.22 (3.29)  | 0.54     |               |
//!
//! (1) LIGGGHTS `epsd2` cannot start from the CDT restart (its wall history
//! has another size). Rolling resistance costs 14–17 %; the JKR kernel costs
//! about 45 %: its contact radius comes from a Newton solve and a
//! `powf(2/3)` per contact. These rows were measured with Γ = 0 before the
//! engine learnt to run the Hertz kernel whenever every surface energy is 0
//! (identical physics), so absent cohesion now costs nothing; the bench's JKR
//! variant uses Γ = 1e-9 J/m² to keep timing the JKR kernel.
//!
//! Per-stage cost (N = 5,120, 1 thread, instrumented build): drift 15,
//! rebuild 1.5, pair forces 131, gather + walls + kick 41, energy check 1 ns
//! per particle-step; the pair kernel is latency-bound (≈ 55 ns per touching
//! pair: one dependent chain of 5 square roots and 4 divisions per contact).
//!
//! # Measured 2026-11-23 (quieter window, nothing else running)
//!
//! Release build, one process at a time, LIGGGHTS 3.8.0 serial with the same
//! decks in the same window; Mps/s, median of 3 segments, spread over
//! repeated runs:
//!
//! | N      | repose 1 thr | repose 2 thr | 2 thr / 1 thr | LIGGGHTS  | ratio 1 thr |
//! |--------|--------------|--------------|---------------|-----------|-------------|
//! | 5,120  | 9.13–9.53    | 17.19–17.52  | 1.84          | 4.37–4.44 | 2.1         |
//! | 50,000 | 5.06–6.30    | 9.20–12.53   | 1.8–2.1       | 2.6–3.4   | 1.64–2.2    |
//!
//! At 5,120 five alternating 1/2-thread pairs gave 1.84× from the second
//! thread (two independent 1-thread processes at once each keep their solo
//! speed, so the host can scale); earlier 1.64× readings were taken with
//! another load on the host. At 50,000 the host's noise (±20 % between
//! windows for both codes) is larger than any remaining difference: run side
//! by side on the two cores at once, repose/LIGGGHTS was 1.84 and 1.50.
//! Profile (`perf record -e cpu-clock`, 1 thread): pair kernel 58 %, gather +
//! kick + drift 34 %, plane wall contact 3 %, neighbour rebuild and re-sort
//! under 1 % at both sizes — the per-particle cost that grows with N
//! (≈ 107 ns at 5,120, ≈ 180 ns at 50,000) is memory, not the search.
//! Tried and not kept: filtering out-of-range pairs before the contact laws
//! (+4–9 % at 5,120, −8 % at 50,000); one contiguous task per thread and
//! stage instead of 256-element tasks (no gain, worse under noise).
//!
//! # Measured 2026-11-25 (one process at a time)
//!
//! Same build and decks; LIGGGHTS and repose alternating in the same window
//! (50,000: L R L R between 14:59 and 15:05, a quiet window; 20,480 and
//! 5,120 around 15:25–15:35, a noisier one; 100,820: one LIGGGHTS run, then
//! one repose run, 16:35–16:50). Mps/s, median of 3 segments (the range of
//! single segments in brackets where the spread matters):
//!
//! | N       | repose 1 thr         | repose 2 thr | LIGGGHTS               | ratio 1 thr |
//! |---------|----------------------|--------------|------------------------|-------------|
//! | 5,120   | 8.41, 9.22 (7.4–9.6) | 14.76, 17.11 | 4.63, 4.38             | 1.8–2.1     |
//! | 20,480  | 6.38 (5.1–6.4) (2)   | 11.10        | 4.24–4.34              | 1.5–1.8     |
//! | 50,000  | 6.78, 6.80           | 13.94, 13.34 | 3.36, 3.46 (3.33–3.67) | 1.97        |
//! | 100,820 | 5.86; 6.34 (1)       | 10.99        | 3.08 (2.83–3.20)       | 2.06        |
//!
//! (1) 6.34 is the run right after the LIGGGHTS one (the ratio's pair);
//! 5.86 an earlier run alone. (2) 7.76 in an earlier run beside a LIGGGHTS
//! settle on the other core.
//!
//! At 50,000 the second thread gives 2.0× (13.3–13.9 against 6.8) and the
//! per-core ratio to LIGGGHTS is 1.97 in the quietest window measured so
//! far; at 100,820 it is 2.06 (one pair of runs). Cost per particle-step
//! on one thread (best medians): 104 ns at 5,120, 129 ns at 20,480, 147 ns
//! at 50,000, 158–171 ns at 100,820 — about 10 % more per doubling of N,
//! still rising at 100,000, so the cost is not yet linear in N. LIGGGHTS rises too: 216 ns at 5,120,
//! 290 ns at 50,000, 325 ns at 100,820. The neighbour search is O(N) and
//! under 1 % of the time, and every stage slows alike (the profile's split
//! does not change with N), which points at the memory hierarchy rather than
//! the algorithm; the experiments that did not remove it are listed in the
//! simulation module's docs.
//!
//! # Measured 2026-11-25, evening (pair forces summed in place, 5ec424a)
//!
//! The pair stage now adds forces straight into per-particle sums (one tile
//! on one thread, so no per-pair records at all; see
//! `dem::simulation::tiles`). Results are bit-identical to the previous
//! engine. Same decks and machine, Mps/s, median of 3 segments:
//!
//! | N      | repose 1 thr       | repose 2 thr  | LIGGGHTS   | ratio 1 thr | window          |
//! |--------|--------------------|---------------|------------|-------------|-----------------|
//! | 50,000 | 7.16               | 12.86         | 3.50       | 2.05        | 18:42–18:50, L R |
//! | 50,000 | 5.85               |               | 2.52, 1.72 | (2.3–3.4)   | 18:54–19:00, noisy |
//! | 50,000 | 5.13 (side by side) |              | 3.22       | 1.59        | 19:00–19:04, both at once |
//! | 20,480 | 6.82               | 11.04         | 2.86       | (2.4)       | 19:08, noisy    |
//! | 5,120  | 6.36; 8.3–9.3      | 11.74         | 4.17       | (1.5–2.2)   | 19:05–19:15, noisy |
//!
//! Against the previous binary (same machine, A/B): at 50,000 on one thread
//! +21 %, +20 % and +12 % in three runs side by side (one core each), −8 %
//! and +38 % in two alternating pairs of solo runs (the host's noise); at
//! 5,120 equal within ±3 % (eight alternating solo runs, 8.3–9.4 against
//! 9.2–9.5); at 50,000 on two threads 13.4–13.9 against 12.9–13.1. The best
//! one-thread cost per particle-step is now 106 ns at 5,120 and 140 ns at
//! 50,000 (1.32× more, against 1.41× before): still not linear in N. Run
//! side by side with LIGGGHTS on the other core, both codes share the L3
//! cache and memory bandwidth, and repose, which asks for about twice the
//! bytes per second, loses more (1.59×). Profile at 50,000 on one thread
//! (`perf record -e cpu-clock`): pair kernel 70 %, gather + kick + drift
//! 18.5 %, plane wall 3.5 %, neighbour rebuild under 1 % (before: 58 % and
//! 34 %); within the kernel no instruction takes more than 5 %.
//!
//! # Measured 2026-11-26 (a quiet window, one process at a time)
//!
//! a717b6f (the engine above), release build; LIGGGHTS 3.8.0 serial right
//! after it with the same decks, 00:55–01:45 UTC with nothing else running
//! (20,480 repeated as LIGGGHTS, repose, LIGGGHTS, repose). Mps/s, median of
//! 3 segments (segments within 1–4 % of their median):
//!
//! | N       | repose 1 thr | repose 2 thr | 2 thr / 1 thr | LIGGGHTS   | ratio 1 thr |
//! |---------|--------------|--------------|---------------|------------|-------------|
//! | 5,120   | 9.48         | 17.17        | 1.81          | 4.73       | 2.00        |
//! | 20,480  | 8.34–8.40    | 15.69        | 1.87          | 4.30–4.41  | 1.90–1.95   |
//! | 50,000  | 8.11         | 15.07        | 1.86          | 3.82       | 2.12        |
//! | 100,820 | 7.54         | 14.04        | 1.86          | 3.12       | 2.42        |
//!
//! Contacts per particle 4.54–4.57 and 0.050–0.051 wall contacts per
//! particle at every size. Cost per particle-step on one thread: repose 105,
//! 119, 123 and 133 ns; LIGGGHTS 211, 227–233, 262 and 321 ns. From 5,120 to
//! 100,820 particles (20× N) repose's cost per particle-step grows 1.26×,
//! LIGGGHTS's 1.52×: every stage of both codes is O(N), and what grows is
//! the price of memory as the working set (≈ 350 B per particle for repose)
//! outgrows the caches (1 MiB L2 per core; a 32 MiB L3 shared with the
//! host's other tenants) — the profile's split between the stages is the
//! same at 5,120 and 50,000 (pair kernel 68–70 %, per-particle pass
//! 18.5–20.5 %, plane wall 3.5–4.4 %). Solo runs just before the window
//! gave 9.50 at 5,120 and 7.93 at 50,000.
//!
//! bd2cf64 (the kick and drift no longer re-read the velocities they have
//! just stored; bit-identical results), same window, 02:08–02:16 UTC:
//!
//! | N      | repose 1 thr | repose 2 thr     | 2 thr / 1 thr | LIGGGHTS | ratio 1 thr |
//! |--------|--------------|------------------|---------------|----------|-------------|
//! | 5,120  | 9.72         | 16.7–17.3 (1)    | 1.72–1.78     | 4.73     | 2.05        |
//! | 20,480 | 8.38–8.56    | 16.02            | 1.87          | 4.10 (2) | 1.95–2.09   |
//! | 50,000 | 8.16         | 14.69            | 1.80          | 3.82     | 2.14        |
//!
//! (1) Undisturbed segments of four runs; 2-thread runs of both a717b6f and
//! bd2cf64 had segments at 11–14 whenever the host took time from one of
//! the two vCPUs (the waiting thread spins). (2) LIGGGHTS at 20,480 over the
//! window: 4.07, 4.10, 4.30, 4.30, 4.32, 4.33, 4.41 (median 4.30); repose
//! 8.38–8.56 (median 8.49): 1.97 median against median, 1.95–2.09 for the
//! pairs run back to back. Side by side against a717b6f on one core each:
//! +7 % and +3 % at 50,000, equal at 5,120; the profile at 5,120 shows the
//! per-particle pass 17 % cheaper.
//!
//! Cost of each effect (bd2cf64, N = 5,120, one thread, same settled bed,
//! Mps/s): Hertz without rolling resistance 9.84, with CDT 9.74, with EPSD
//! 9.26; the JKR kernel (Γ = 1e-9 J/m²) 4.18, 4.19 and 3.95. Rolling
//! resistance now costs 1 % (CDT) and 6 % (EPSD); the JKR kernel 2.3× the
//! time of the Hertz one (its Newton solve for the contact radius); JKR with
//! Γ = 0 runs the Hertz kernel and costs nothing.
//!
//! 3be6676 (the pair kernel's AVX-512 copy, see
//! [`has_avx512`](crate::dem::lanes::has_avx512); bit-identical results),
//! 04:12–04:37 UTC, one process at a time, LIGGGHTS right after repose at
//! each size:
//!
//! | N       | repose 1 thr | repose 2 thr  | 2 thr / 1 thr | LIGGGHTS   | ratio 1 thr |
//! |---------|--------------|---------------|---------------|------------|-------------|
//! | 5,120   | 10.17        | 18.04         | 1.77          | 4.63       | 2.20        |
//! | 20,480  | 9.27, 9.29   | 16.25, 17.11  | 1.75, 1.84    | 4.10, 4.38 | 2.26, 2.12  |
//! | 50,000  | 8.16         | 15.43         | 1.89          | 3.85       | 2.12        |
//! | 100,820 | 7.65         | 13.52         | 1.77          | 3.29       | 2.33        |
//!
//! Cost per particle-step on one thread: repose 98, 108, 123 and 131 ns
//! (1.33× over 20× N), LIGGGHTS 216, 228–244, 260 and 304 ns (1.41×). Side
//! by side against 63535be on one core each (four pairs, settled 8,000
//! steps): +6 % at 5,120, +8–10 % at 20,480 and +8–11 % at 50,000.
//! Compiling the whole program for x86-64-v4 was no faster than the kernel's
//! copy alone at 5,120; eight contacts at a time (two four-lane halves) in the
//! AVX-512 copy was 12 % slower than four.
//!
//! Where the second thread's time goes (5,120 particles, wall time per step,
//! timed around the stages in a scratch build): on one thread the pair sweep
//! takes 371 µs, the per-particle pass 117 µs and neighbour rebuilds 7 µs
//! (amortised); on two, 193, 77 and 5 µs. The pair sweep scales 1.92×; the
//! per-particle pass only 1.52×, and neither one tile per thread instead of
//! two nor handing each thread one contiguous half of the particles in the
//! per-particle pass changed that (75–81 µs). That pass streams about 470 B
//! per particle and step, about 20 GB/s on one core; the likeliest limit on
//! two is the cache bandwidth both cores share, but I have not shown it.
//! Rayon's idle thread falling asleep is not it: `perf stat` counts 0.56
//! context switches per step on two threads, about one sleep and wake every
//! four steps.
//!
//! Leaving a particle's empty wall history unwritten when it touches no wall
//! (24 B fewer written per particle, wall and step): +1 % at 5,120 and +2 %
//! at 50,000, mean of four side-by-side pairs each, within the host's noise;
//! kept because it costs one comparison.
//!
//! Cost of each effect after the JKR contact radius is solved four contacts
//! at a time (95ccc67: Newton per lane, each lane stopping on its own test,
//! bit-identical), N = 5,120, one thread, Mps/s: Hertz without rolling
//! resistance 10.20, with CDT 10.27, with EPSD 9.57; the JKR kernel 6.19,
//! 6.15 and 6.23 (before: 4.18 with CDT, side by side 4.18 against 6.29).
//! The JKR kernel now takes 1.65× the time of the Hertz one.
//!
//! # Measured 2026-11-26, 11:25–11:42 (the team, one job per member; segments in rounds)
//!
//! 7e53417: the stages run on a persistent team of threads, one tile per
//! member; the benchmark runs its segments in rounds, so each 2-thread
//! segment is paired with the 1-thread segment just before it. Five
//! segments per variant, LIGGGHTS right after repose at each size, one
//! process at a time on a host that was loaded throughout (LIGGGHTS ran
//! 3.2–3.6 Mps/s at 20,480, against 4.1–4.4 in the quiet windows above).
//! Mps/s, median of the segments; speedup = median of the per-round ratios:
//!
//! | N       | repose 1 thr            | repose 2 thr               | speedup                | LIGGGHTS | ratio 1 thr |
//! |---------|-------------------------|----------------------------|------------------------|----------|-------------|
//! | 5,120   | 9.48, 9.31, 9.52, 10.08 | 17.36, 14.56, 16.42, 15.04 | 1.78, 1.55, 1.83, 1.45 | 4.55     | 2.05–2.22   |
//! | 20,480  | 8.82                    | 16.37                      | 1.92                   | 3.50     | 2.52        |
//! | 50,000  | 8.20                    | 15.77                      | 1.86                   | 3.25     | 2.52        |
//! | 100,820 | 7.25                    | 12.59                      | 1.74                   |          |             |
//!
//! Per-round ratios at 5,120 in the first and third runs: 1.78, 1.85,
//! 1.86, 1.49, 1.09 and 1.84, 1.84, 1.32, 2.00, 1.81; the rounds whose
//! segments the host left alone give 1.78–1.86, and a disturbed round
//! drops to 1.1–1.5 (a member kept off its CPU holds up every stage it
//! has a job in). At 50,000 the rounds gave 1.73, 1.86, 1.86, 1.98, 1.85.
//! The ratios to LIGGGHTS are inflated by the loaded window; the quiet
//! windows above give 2.1–2.3.
//!
//! What the second thread costs: with `t` tiles the pair sweep has `t`
//! boundaries (the last one the periodic wrap), and about one cell slab of
//! particles beyond each is a head, gathered from the pair buffer at about
//! three times the cost of a particle whose sum is ready. Counted on the
//! settled bed with four tiles: 16.9 % heads at 5,120, 8.2 % at 20,480,
//! 5.3 % at 50,000, 3.8 % at 100,820 (28.4, 13.9, 8.9 and 6.3 % of the
//! listed pairs buffered); two tiles have two boundaries instead of four,
//! so about half as many (not counted). One thread has no
//! heads, so the per-particle pass does more work on two threads than on
//! one, most at 5,120 — the size whose speedup stays below 1.9.
//!
//! Beyond the caches the cost is flat: one thread, 11:45–12:00, 100,820
//! particles 7.77 Mps/s (segments 6.79, 7.77, 7.90), 200,000 particles
//! (`--n 100`) 7.78 (7.57, 7.85, 7.78) — 128.7 and 128.5 ns per
//! particle-step, 4.54 contacts per particle at both. Doubling N past the
//! step the working set takes out of the caches doubles the time.
//!
//! # Measured 2026-11-26, 13:35–13:57 (blocks: no heads on any thread count)
//!
//! a2cee74: every particle sums its own block's pairs in place and each
//! earlier block's in a partial (`dem::simulation` `tiles`); the blocks
//! never depend on the thread count, so one and two threads do the same
//! work and nothing is gathered from a per-pair buffer. Five segments per
//! variant, LIGGGHTS right after repose at each size, one process at a
//! time; a quiet window at first (two single-thread repose processes side
//! by side each ran 10.06–10.18 Mps/s at 5,120, against 10.21 alone: two
//! real cores). Mps/s, median of the segments; speedup = median of the
//! per-round ratios; "cpu" = Mps/s per CPU-second of the process:
//!
//! | N       | repose 1 thr | repose 2 thr (cpu) | speedup | LIGGGHTS | ratio 1 thr |
//! |---------|--------------|--------------------|---------|----------|-------------|
//! | 5,120   | 10.24        | 19.08 (9.57)       | 1.87    | 4.58     | 2.24        |
//! | 20,480  | 8.64         | 15.69 (7.94)       | 1.92    | 4.09     | 2.11        |
//! | 50,000  | 8.20         | 15.57 (7.90)       | 1.88    | 3.78     | 2.17        |
//! | 100,820 | 7.62         | 15.07 (7.64)       | 1.97    |          |             |
//!
//! Eight more runs at 5,120 in the next 25 minutes gave speedups 1.78,
//! 1.79, 1.78, 1.47, 1.85, 1.60, 1.87 and 1.87: the runs the host left
//! alone give 1.85–1.87 (per-round ratios 1.83–1.88; before the blocks,
//! 1.78–1.86), and a run in which another tenant took CPU time (2-thread
//! segments dropping to 14–16 Mps/s for seconds, the CPU-time throughput
//! with them) lower. Stage timers (a temporary build, quiet rounds of the
//! same run): the pair sweep took 2.266 s on one thread and 1.144 s on two
//! (1.98×), the per-particle pass 0.714 s and 0.413 s (1.73×: each stage
//! ends at a barrier, about 2 µs per step on this VM, and the pass is
//! short, 24 µs per step on one thread). Tried: eight blocks at 5,120 with
//! four jobs per team member, so that a member whose CPU is taken leaves
//! untaken jobs to the other: no better in disturbed runs (1.77, 1.65,
//! 1.83 against 1.85, 1.60, 1.87 alternating) and 3 % slower on two
//! threads in quiet rounds (18.5 against 19.1–19.4 Mps/s), so one job per
//! member stays.

use std::io::Write;
use std::time::Instant;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::{ThreadPool, ThreadPoolBuilder};
use serde::Serialize;

use crate::dem::contact::PairParameters;
use crate::dem::domain::Domain;
use crate::dem::health::{HealthError, HealthLimits};
use crate::dem::material::ElasticMaterial;
use crate::dem::particles::{ParticleInit, Particles};
use crate::dem::simulation::{
    ContactSetup, NormalChoice, RollingChoice, SetupError, Simulation, SimulationSetup, World,
};
use crate::dem::vec3::Vec3;
use crate::dem::walls::Wall;

/// Sphere radius, m.
const RADIUS_M: f64 = 1e-3;
/// Lattice spacing, m.
const SPACING_M: f64 = 2.4e-3;
/// Largest jitter per axis, m.
const JITTER_M: f64 = 2e-4;
/// Layers of the lattice.
const LAYERS: usize = 20;
/// Time step, s (the decks' `timestep`).
pub const DT_S: f64 = 2.4477e-5;
/// Verlet skin, m (the decks' `neighbor 0.0002 bin`).
const SKIN_M: f64 = 2e-4;

/// What to benchmark.
#[derive(Clone, Debug, PartialEq)]
pub struct BenchOptions {
    /// Lattice side: N = n·n·20 spheres (16, 32, 50 give 5,120, 20,480, 50,000).
    pub n: usize,
    /// Thread counts to time, each in its own rayon pool.
    pub threads: Vec<usize>,
    /// Steps per timed segment; `None`: the deck's (6,000 / 2,000 / 1,000).
    pub steps: Option<u64>,
    /// Timed segments per variant.
    pub segments: usize,
    /// Warm-up steps before the timed segments.
    pub warmup: u64,
    /// Settling steps; `None`: the deck's (20,000; 16,000 for n ≥ 50).
    pub settle: Option<u64>,
    /// Normal models to time (JKR runs with [`JKR_SURFACE_ENERGY_J_M2`]).
    pub normals: Vec<NormalChoice>,
    /// Rolling models to time.
    pub rollings: Vec<RollingChoice>,
    /// Seed of the lattice jitter.
    pub seed: u64,
}

impl BenchOptions {
    /// The deck's settings for lattice side `n`: Hertz + CDT on one thread.
    pub fn deck(n: usize) -> Self {
        Self {
            n,
            threads: vec![1],
            steps: None,
            segments: 3,
            warmup: 500,
            settle: None,
            normals: vec![NormalChoice::Hertz],
            rollings: vec![RollingChoice::Cdt],
            seed: 15_485_863,
        }
    }

    /// Number of spheres, n·n·20.
    pub fn particles(&self) -> usize {
        self.n * self.n * LAYERS
    }

    /// Steps per timed segment (given or the deck's).
    pub fn segment_steps(&self) -> u64 {
        self.steps.unwrap_or(match self.n {
            0..=31 => 6000,
            32..=49 => 2000,
            _ => 1000,
        })
    }

    /// Settling steps (given or the deck's).
    pub fn settle_steps(&self) -> u64 {
        self.settle
            .unwrap_or(if self.n >= 50 { 16_000 } else { 20_000 })
    }
}

/// Why a benchmark could not run.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// An option is out of range.
    #[error("invalid option {name}: {message}")]
    Option {
        /// The option.
        name: &'static str,
        /// What is allowed.
        message: &'static str,
    },
    /// The rayon pool could not be built.
    #[error("thread pool: {0}")]
    ThreadPool(#[from] rayon::ThreadPoolBuildError),
    /// The simulation rejected the bed.
    #[error("setup: {0}")]
    Setup(#[from] SetupError),
    /// The bed became unhealthy.
    #[error(transparent)]
    Health(#[from] HealthError),
    /// Writing progress failed.
    #[error("cannot write progress: {0}")]
    Progress(#[from] std::io::Error),
}

impl BenchError {
    /// True when the user's options are at fault.
    pub fn is_invalid_input(&self) -> bool {
        matches!(self, BenchError::Option { .. })
    }
}

/// The settling phase.
#[derive(Clone, Debug, Serialize)]
pub struct SettleReport {
    /// Steps run.
    pub steps: u64,
    /// Threads used.
    pub threads: usize,
    /// Wall time, s.
    pub wall_s: f64,
    /// Highest sphere centre at the end, m.
    pub top_z_m: f64,
    /// Kinetic energy at the end, J.
    pub kinetic_energy_j: f64,
}

/// One timed variant.
#[derive(Clone, Debug, Serialize)]
pub struct VariantReport {
    /// The kernel's name (its effects).
    pub kernel: String,
    /// Threads of the pool.
    pub threads: usize,
    /// Steps per timed segment.
    pub segment_steps: u64,
    /// Throughput of each segment, million particle-steps per second.
    pub segment_mps: Vec<f64>,
    /// Median of `segment_mps`.
    pub median_mps: f64,
    /// Throughput of each segment per CPU second of the process (all its
    /// threads), million particle-steps per CPU second; empty where the CPU
    /// clock (`/proc/self/stat`) is unavailable. On a shared machine this is
    /// less sensitive than wall time to other processes' load.
    pub segment_cpu_mps: Vec<f64>,
    /// Median of `segment_cpu_mps` (0 when empty).
    pub median_cpu_mps: f64,
    /// Median over the rounds of this variant's throughput over that of the
    /// same kernel on the fewest threads timed, in the same round (1 for
    /// that variant itself): the speedup from the extra threads, measured
    /// segment by segment so that the machine's changing speed cancels.
    pub speedup: f64,
    /// Force-carrying particle pairs per particle at the end.
    pub pairs_per_particle: f64,
    /// Particle contacts per particle (2 × pairs per particle).
    pub contacts_per_particle: f64,
    /// Wall contacts per particle at the end.
    pub wall_contacts_per_particle: f64,
    /// Neighbour-list rebuilds during the timed segments.
    pub rebuilds: u64,
    /// Setup (first neighbour build and forces) wall time, s.
    pub setup_s: f64,
    /// Warm-up wall time, s.
    pub warmup_s: f64,
    /// Wall time of all timed segments, s.
    pub timed_s: f64,
}

/// Everything one `repose bench` measured.
#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    /// Lattice side n.
    pub n: usize,
    /// Spheres, n·n·20.
    pub particles: usize,
    /// Time step, s.
    pub dt_s: f64,
    /// The instruction set the pair kernel ran on
    /// ([`pair_kernel_isa`](crate::dem::lanes::pair_kernel_isa)).
    pub pair_kernel_isa: &'static str,
    /// The settling phase.
    pub settle: SettleReport,
    /// Timed variants, in the order run.
    pub variants: Vec<VariantReport>,
}

/// The jittered lattice, the periodic box and the floor.
pub fn bed_world(n: usize, seed: u64) -> World {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut particles = Particles::default();
    let density = bed_setup(NormalChoice::Hertz, RollingChoice::Cdt).density_kg_m3;
    let mut jitter = || JITTER_M * (2.0 * rng.random::<f64>() - 1.0);
    for k in 0..LAYERS {
        for j in 0..n {
            for i in 0..n {
                let lattice = Vec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 1.5) * SPACING_M;
                let offset = Vec3::new(jitter(), jitter(), jitter());
                particles.push(
                    &ParticleInit {
                        position: lattice + offset,
                        velocity: Vec3::zeros(),
                        angular_velocity: Vec3::zeros(),
                        radius_m: RADIUS_M,
                    },
                    density,
                );
            }
        }
    }
    let side = n as f64 * SPACING_M;
    let top = (LAYERS + 2) as f64 * SPACING_M;
    World::new(
        particles,
        vec![Wall::plane(Vec3::zeros(), Vec3::z(), 0).expect("the floor is a valid plane")],
        Domain::new(
            Vec3::zeros(),
            Vec3::new(side, side, top),
            [true, true, false],
        )
        .expect("the bed's box is valid"),
    )
}

/// Surface energy the JKR variant uses, J/m²: physically negligible (the
/// pull-off force of a 1 mm pair is 5e-12 N against a 1e-4 N weight), but not
/// zero, because with Γ = 0 everywhere the engine runs the Hertz kernel.
pub const JKR_SURFACE_ENERGY_J_M2: f64 = 1e-9;

/// The deck's physics with the given normal and rolling models (JKR with
/// [`JKR_SURFACE_ENERGY_J_M2`]).
pub fn bed_setup(normal: NormalChoice, rolling: RollingChoice) -> SimulationSetup {
    let material = ElasticMaterial {
        youngs_modulus_pa: 5e6,
        poisson_ratio: 0.3,
    };
    let pair = PairParameters {
        restitution: 0.5,
        static_friction: 0.5,
        rolling_friction: 0.1,
        surface_energy_j_m2: match normal {
            NormalChoice::Hertz => 0.0,
            NormalChoice::Jkr => JKR_SURFACE_ENERGY_J_M2,
        },
    };
    SimulationSetup {
        contact: ContactSetup {
            normal,
            rolling,
            clip_tensile: false,
            particle_material: material,
            particle_particle: pair,
            wall_materials: vec![(material, pair)],
        },
        density_kg_m3: 2500.0,
        gravity_m_s2: Some(Vec3::new(0.0, 0.0, -9.81)),
        dt_s: DT_S,
        skin_m: SKIN_M,
        health: HealthLimits::default(),
    }
}

/// Settles the bed (progress to `progress`), then times every variant.
pub fn run(
    options: &BenchOptions,
    progress: &mut (dyn Write + Send),
) -> Result<BenchReport, BenchError> {
    check(options)?;
    let n_part = options.particles();
    let settle_threads = options.threads.iter().copied().max().unwrap_or(1);
    let settle_steps = options.settle_steps();
    writeln!(
        progress,
        "settling N = {n_part} for {settle_steps} steps on {settle_threads} thread(s)"
    )?;
    let pool = ThreadPoolBuilder::new()
        .num_threads(settle_threads)
        .build()?;
    let start = Instant::now();
    let settled = pool.install(|| -> Result<World, BenchError> {
        let world = bed_world(options.n, options.seed);
        let mut sim = Simulation::new(world, &bed_setup(NormalChoice::Hertz, RollingChoice::Cdt))?;
        let chunk = settle_steps.div_ceil(10).max(1);
        let mut done = 0;
        while done < settle_steps {
            let k = chunk.min(settle_steps - done);
            sim.advance(k)?;
            done += k;
            let s = sim.stats();
            writeln!(
                progress,
                "  step {done}: {:.2} contacts/particle, KE {:.3e} J, {:.1} s",
                2.0 * s.contacts as f64 / n_part as f64,
                sim.world().particles.kinetic_energy_j(),
                start.elapsed().as_secs_f64()
            )?;
        }
        Ok(sim.world().clone())
    })?;
    let p = &settled.particles;
    let settle = SettleReport {
        steps: settle_steps,
        threads: settle_threads,
        wall_s: start.elapsed().as_secs_f64(),
        top_z_m: p.position.iter().map(|x| x.z).fold(f64::MIN, f64::max),
        kinetic_energy_j: p.kinetic_energy_j(),
    };
    let mut timings = Vec::new();
    for &normal in &options.normals {
        for &rolling in &options.rollings {
            for &threads in &options.threads {
                timings.push(VariantTiming::start(
                    options, &settled, normal, rolling, threads,
                )?);
            }
        }
    }
    for round in 0..options.segments {
        for timing in &mut timings {
            timing.segment(options, round, progress)?;
        }
    }
    let mut variants: Vec<VariantReport> = timings.into_iter().map(|t| t.finish(options)).collect();
    set_speedups(&mut variants);
    Ok(BenchReport {
        n: options.n,
        particles: n_part,
        dt_s: DT_S,
        pair_kernel_isa: crate::dem::lanes::pair_kernel_isa(),
        settle,
        variants,
    })
}

fn check(options: &BenchOptions) -> Result<(), BenchError> {
    let fail = |name, message| Err(BenchError::Option { name, message });
    if !(2..=400).contains(&options.n) {
        return fail("--n", "the lattice side must be in 2..=400");
    }
    if options.threads.is_empty() || options.threads.contains(&0) {
        return fail("--threads", "thread counts must be >= 1");
    }
    if options.segments == 0 || options.segment_steps() == 0 {
        return fail("--segments/--steps", "at least one segment of >= 1 step");
    }
    if options.normals.is_empty() || options.rollings.is_empty() {
        return fail("--normal/--rolling", "at least one model each");
    }
    Ok(())
}

/// One variant being timed: its pool, its simulation and what its segments
/// measured so far.
struct VariantTiming {
    pool: ThreadPool,
    sim: Simulation,
    threads: usize,
    /// Neighbour rebuilds before the first timed segment.
    rebuilds_before: u64,
    /// Set-up and warm-up wall times, s.
    setup_s: f64,
    warmup_s: f64,
    /// Per segment: M particle-steps per wall second and per CPU second.
    segment_mps: Vec<f64>,
    segment_cpu_mps: Vec<f64>,
    /// Wall time of the timed segments so far, s.
    timed_s: f64,
}

impl VariantTiming {
    /// A fresh simulation of the settled bed with the variant's laws in a
    /// pool of `threads` threads, set up and warmed up (both timed).
    fn start(
        options: &BenchOptions,
        settled: &World,
        normal: NormalChoice,
        rolling: RollingChoice,
        threads: usize,
    ) -> Result<Self, BenchError> {
        let pool = ThreadPoolBuilder::new().num_threads(threads).build()?;
        let (sim, setup_s, warmup_s) = pool.install(|| -> Result<_, BenchError> {
            let t0 = Instant::now();
            let mut sim = Simulation::new(settled.clone(), &bed_setup(normal, rolling))?;
            let setup_s = t0.elapsed().as_secs_f64();
            let t1 = Instant::now();
            sim.advance(options.warmup)?;
            Ok((sim, setup_s, t1.elapsed().as_secs_f64()))
        })?;
        Ok(Self {
            pool,
            threads,
            rebuilds_before: sim.stats().rebuilds,
            sim,
            setup_s,
            warmup_s,
            segment_mps: Vec::with_capacity(options.segments),
            segment_cpu_mps: Vec::with_capacity(options.segments),
            timed_s: 0.0,
        })
    }

    /// Spheres in the bed, as a float for throughputs.
    fn particles(&self) -> f64 {
        self.sim.world().particles.len() as f64
    }

    /// Times segment `round` (0-based) in the variant's pool.
    fn segment(
        &mut self,
        options: &BenchOptions,
        round: usize,
        progress: &mut (dyn Write + Send),
    ) -> Result<(), BenchError> {
        let steps = options.segment_steps();
        let work = self.particles() * steps as f64 / 1e6;
        let sim = &mut self.sim;
        let (t, cpu) = (Instant::now(), process_cpu_s());
        self.pool.install(|| sim.advance(steps))?;
        let wall_s = t.elapsed().as_secs_f64();
        let mps = work / wall_s;
        let cpu_mps = cpu
            .zip(process_cpu_s())
            .map(|(a, b)| work / (b - a).max(1e-2));
        writeln!(
            progress,
            "  {}, {} thread(s), segment {} of {}: {mps:.2} M particle-steps/s, {:.2} per CPU s",
            self.sim.kernel_name(),
            self.threads,
            round + 1,
            options.segments,
            cpu_mps.unwrap_or(0.0)
        )?;
        self.segment_mps.push(mps);
        self.segment_cpu_mps.extend(cpu_mps);
        self.timed_s += wall_s;
        Ok(())
    }

    /// The variant's report (speedup 1 until [`set_speedups`]), with the
    /// bed's contacts at the end.
    fn finish(self, options: &BenchOptions) -> VariantReport {
        let n = self.particles();
        let s = self.sim.stats();
        VariantReport {
            kernel: self.sim.kernel_name(),
            threads: self.threads,
            segment_steps: options.segment_steps(),
            median_mps: median(&self.segment_mps),
            segment_mps: self.segment_mps,
            median_cpu_mps: if self.segment_cpu_mps.is_empty() {
                0.0
            } else {
                median(&self.segment_cpu_mps)
            },
            segment_cpu_mps: self.segment_cpu_mps,
            speedup: 1.0,
            pairs_per_particle: s.contacts as f64 / n,
            contacts_per_particle: 2.0 * s.contacts as f64 / n,
            wall_contacts_per_particle: s.wall_contacts as f64 / n,
            rebuilds: s.rebuilds - self.rebuilds_before,
            setup_s: self.setup_s,
            warmup_s: self.warmup_s,
            timed_s: self.timed_s,
        }
    }
}

/// Sets each variant's [`speedup`](VariantReport::speedup): the median over
/// the rounds of its throughput over that of the same kernel on the fewest
/// threads in the same round.
fn set_speedups(variants: &mut [VariantReport]) {
    let speedups: Vec<f64> = variants
        .iter()
        .map(|v| {
            let base = variants
                .iter()
                .filter(|b| b.kernel == v.kernel)
                .min_by_key(|b| b.threads)
                .unwrap_or(v);
            let ratios: Vec<f64> = v
                .segment_mps
                .iter()
                .zip(&base.segment_mps)
                .map(|(m, b)| m / b)
                .collect();
            median(&ratios)
        })
        .collect();
    for (v, s) in variants.iter_mut().zip(speedups) {
        v.speedup = s;
    }
}

/// User + system CPU time of this process (all threads), s, from
/// `/proc/self/stat` (clock ticks of 1/100 s); `None` where unavailable.
fn process_cpu_s() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let rest = &stat[stat.rfind(')')? + 2..];
    let mut fields = rest.split_whitespace().skip(11);
    let utime: f64 = fields.next()?.parse().ok()?;
    let stime: f64 = fields.next()?.parse().ok()?;
    Some((utime + stime) / 100.0)
}

/// Median of a non-empty list (mean of the middle two for even lengths).
fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let m = s.len() / 2;
    if s.len() % 2 == 1 {
        s[m]
    } else {
        0.5 * (s[m - 1] + s[m])
    }
}

impl BenchReport {
    /// Writes the report as a text table.
    pub fn write_table(&self, out: &mut dyn Write) -> std::io::Result<()> {
        writeln!(
            out,
            "bed: N = {} ({} x {} x {LAYERS}), dt = {:e} s, pair kernel on {}; settled in {} steps, {:.1} s on {} thread(s), top z = {:.2} mm",
            self.particles,
            self.n,
            self.n,
            self.dt_s,
            self.pair_kernel_isa,
            self.settle.steps,
            self.settle.wall_s,
            self.settle.threads,
            self.settle.top_z_m * 1e3
        )?;
        writeln!(
            out,
            "{:<34} {:>3} {:>6}  {:<23} {:>7} {:>7} {:>7} {:>7} {:>7} {:>6} {:>5} {:>8} {:>8}",
            "kernel",
            "thr",
            "steps",
            "segments Mps/s",
            "median",
            "speedup",
            "cpu Mps",
            "pairs/p",
            "cont/p",
            "wall/p",
            "rebld",
            "warmup s",
            "timed s"
        )?;
        for v in &self.variants {
            let segs: Vec<String> = v.segment_mps.iter().map(|m| format!("{m:.2}")).collect();
            writeln!(
                out,
                "{:<34} {:>3} {:>6}  {:<23} {:>7.2} {:>7.2} {:>7.2} {:>7.3} {:>7.3} {:>6.3} {:>5} {:>8.2} {:>8.2}",
                v.kernel,
                v.threads,
                v.segment_steps,
                segs.join(" "),
                v.median_mps,
                v.speedup,
                v.median_cpu_mps,
                v.pairs_per_particle,
                v.contacts_per_particle,
                v.wall_contacts_per_particle,
                v.rebuilds,
                v.warmup_s,
                v.timed_s
            )?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lattice_matches_the_deck() {
        let w = bed_world(4, 1);
        assert_eq!(w.particles.len(), 4 * 4 * 20);
        let z: Vec<f64> = w.particles.position.iter().map(|p| p.z).collect();
        let (lo, hi) = z
            .iter()
            .fold((f64::MAX, f64::MIN), |a, &z| (a.0.min(z), a.1.max(z)));
        // Layers k = 1..=20 of `lattice sc 0.0024 origin 0.5 0.5 0.5`, ±0.2 mm.
        assert!(lo >= 1.5 * SPACING_M - JITTER_M && hi <= 20.5 * SPACING_M + JITTER_M);
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
    }

    /// A report of `kernel` on `threads` threads with these segments.
    fn timed(kernel: &str, threads: usize, segment_mps: Vec<f64>) -> VariantReport {
        VariantReport {
            kernel: kernel.into(),
            threads,
            segment_steps: 1,
            median_mps: median(&segment_mps),
            segment_mps,
            segment_cpu_mps: Vec::new(),
            median_cpu_mps: 0.0,
            speedup: 0.0,
            pairs_per_particle: 0.0,
            contacts_per_particle: 0.0,
            wall_contacts_per_particle: 0.0,
            rebuilds: 0,
            setup_s: 0.0,
            warmup_s: 0.0,
            timed_s: 0.0,
        }
    }

    #[test]
    fn speedups_pair_the_segments_of_one_round() {
        // Round 2 ran while the machine was slow: per round the 2-thread
        // variant did 1.8, 2.0 and 1.7 times the 1-thread one, median 1.8;
        // the ratio of the medians would be 17 / 10 = 1.7.
        let mut v = vec![
            timed("a", 1, vec![10.0, 5.0, 10.0]),
            timed("b", 1, vec![4.0, 4.0, 4.0]),
            timed("a", 2, vec![18.0, 10.0, 17.0]),
        ];
        set_speedups(&mut v);
        let speedups: Vec<f64> = v.iter().map(|v| v.speedup).collect();
        assert_eq!(speedups, vec![1.0, 1.0, 18.0 / 10.0]);
    }

    #[test]
    fn a_tiny_bed_settles_and_times() {
        let mut o = BenchOptions::deck(3);
        o.settle = Some(50);
        o.steps = Some(20);
        o.warmup = 10;
        o.segments = 2;
        o.threads = vec![1, 2];
        o.rollings = vec![RollingChoice::None, RollingChoice::Epsd];
        o.normals = vec![NormalChoice::Jkr];
        let r = run(&o, &mut std::io::sink()).unwrap();
        assert_eq!(r.variants.len(), 4);
        assert!(r.variants.iter().all(|v| v.median_mps > 0.0));
        assert!(r.variants.iter().all(|v| v.segment_mps.len() == 2));
        let one_thread: Vec<f64> = r
            .variants
            .iter()
            .filter(|v| v.threads == 1)
            .map(|v| v.speedup)
            .collect();
        assert_eq!(one_thread, vec![1.0, 1.0]);
        assert!(r.variants[0]
            .kernel
            .starts_with("jkr+mindlin+none+gravity+periodic"));
        let mut bad = o.clone();
        bad.threads = vec![0];
        assert!(run(&bad, &mut std::io::sink())
            .unwrap_err()
            .is_invalid_input());
    }
}
