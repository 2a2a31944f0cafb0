//! A team of threads that stays awake through the stages of a step, each
//! member always taking the same share of the work.
//!
//! A team member takes share `t` every time (rayon's fork-join would hand
//! a region's parts to whichever worker comes first) and spins between the stages
//! (they follow each other within microseconds). Between the parts of a run
//! that are not the team's (neighbour rebuilds, which are rayon's, and the
//! caller's own work between `advance` calls) the caller sends it to rest:
//! its helpers then yield their CPUs at every look, and park after
//! [`PARK_AFTER`], so an idle simulation costs no CPU.
//!
//! Results never depend on the team: each share's work and the order its
//! results are combined in are fixed by the caller.
//!
//! Measurements and what was tried: docs/performance.md ("src/dem/simulation/team.rs").

use std::any::Any;
use std::panic::{catch_unwind, resume_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// How long a thread waiting for the team spins before it starts yielding
/// its CPU at every look: the stages of one step follow each other within
/// microseconds, but a thread the system put on the same CPU as the one it
/// waits for must let that one run.
const SPIN: Duration = Duration::from_micros(50);

/// How long a helper waits for the next task, yielding, before it parks: a
/// paused simulation stops costing CPU after this. Parking is kept for long
/// pauses only: waking a parked thread is a system call, dearer on a virtual
/// machine, and parking at every neighbour rebuild was slower than spinning
/// through it.
///
/// Measured: docs/performance.md ("src/dem/simulation/team.rs").
const PARK_AFTER: Duration = Duration::from_millis(5);

/// A task handed to the members: `task(t)` runs share `t`. Lifetime-erased;
/// [`Team::run`] does not return before every member is done with it.
#[derive(Clone, Copy)]
struct TaskRef(*const (dyn Fn(usize) + Sync));

// SAFETY: the pointee is `Sync` and outlives every use (see `Team::run`).
unsafe impl Send for TaskRef {}

/// Jobs per team member in each stage (tiles of the pair sweep, runs of the
/// per-particle passes): one. A member done with its job still takes the
/// job of a member that has not started its own (see
/// [`Team::for_each`]).
///
/// More jobs per member would let a member take over part of a held-up
/// share, but with the blocks of `tiles` more jobs need more blocks, and
/// they were no better when a member was held up and slower when none was.
///
/// Measured: docs/performance.md ("src/dem/simulation/team.rs").
pub(super) const JOBS_PER_MEMBER: usize = 1;

/// Runs `jobs` on `team` (see [`Team::for_each`]), or all of them here in
/// order without a team; returns the results in job order.
pub(super) fn run_jobs<J: Send, R: Send>(
    team: Option<&Team>,
    jobs: Vec<J>,
    work: impl Fn(J) -> R + Sync,
) -> Vec<R> {
    match team {
        Some(team) => team.for_each(jobs, work),
        None => jobs.into_iter().map(work).collect(),
    }
}

/// What the caller and its helpers share.
struct Shared {
    /// Bumped for every task (and to stop).
    generation: AtomicU64,
    task: Mutex<Option<TaskRef>>,
    /// Helpers done with the current task.
    finished: AtomicUsize,
    /// Per helper: parked, or about to park.
    sleeping: Vec<AtomicBool>,
    /// Yield at once instead of spinning (set between uses).
    rest: AtomicBool,
    stop: AtomicBool,
    /// The first panic of a helper in the current task.
    panic: Mutex<Option<Box<dyn Any + Send>>>,
}

/// The calling thread (share 0) and `size − 1` helper threads.
pub(super) struct Team {
    shared: Arc<Shared>,
    helpers: Vec<JoinHandle<()>>,
}

impl Team {
    /// A team of `size` (≥ 2) threads: the caller of [`run`](Self::run) and
    /// `size − 1` helpers spawned here.
    pub(super) fn new(size: usize) -> Self {
        let helpers = size.saturating_sub(1);
        let shared = Arc::new(Shared {
            generation: AtomicU64::new(0),
            task: Mutex::new(None),
            finished: AtomicUsize::new(0),
            sleeping: (0..helpers).map(|_| AtomicBool::new(false)).collect(),
            rest: AtomicBool::new(true),
            stop: AtomicBool::new(false),
            panic: Mutex::new(None),
        });
        let helpers = (0..helpers)
            .map(|k| {
                let shared = Arc::clone(&shared);
                std::thread::Builder::new()
                    .name(format!("repose-team-{}", k + 1))
                    .spawn(move || helper(&shared, k))
                    .expect("the system can start a thread")
            })
            .collect();
        Self { shared, helpers }
    }

    /// Threads in the team, the caller included.
    pub(super) fn size(&self) -> usize {
        self.helpers.len() + 1
    }

    /// Runs `task(t)` for every share `t` in `0..size`, share 0 on the
    /// calling thread; returns when all are done. A panic in any share is
    /// passed on to the caller once every share has stopped.
    pub(super) fn run(&self, task: &(dyn Fn(usize) + Sync)) {
        let s = &*self.shared;
        // SAFETY (of the lifetime erasure): `WaitForHelpers` below does not
        // let this function return or unwind before every helper has
        // finished the task, and no helper touches it after that.
        let erased: TaskRef = TaskRef(unsafe {
            std::mem::transmute::<*const (dyn Fn(usize) + Sync + '_), *const (dyn Fn(usize) + Sync)>(
                task,
            )
        });
        *s.task.lock().unwrap_or_else(|e| e.into_inner()) = Some(erased);
        s.finished.store(0, Ordering::Relaxed);
        s.rest.store(false, Ordering::SeqCst);
        s.generation.fetch_add(1, Ordering::SeqCst);
        self.wake();
        let wait = WaitForHelpers {
            shared: s,
            helpers: self.helpers.len(),
        };
        task(0);
        drop(wait);
        if let Some(payload) = s.panic.lock().unwrap_or_else(|e| e.into_inner()).take() {
            resume_unwind(payload);
        }
    }

    /// Runs `jobs` (a whole number per member, [`JOBS_PER_MEMBER`]) and
    /// returns their results in job order. Member `t` owns the `t`-th run of
    /// consecutive jobs and takes them in order; a member done with its own
    /// takes the next untaken job of the others, so that a member the system
    /// keeps off its CPU for a while (another process on a shared machine)
    /// delays the stage by less than its whole share.
    pub(super) fn for_each<J: Send, R: Send>(
        &self,
        jobs: Vec<J>,
        work: impl Fn(J) -> R + Sync,
    ) -> Vec<R> {
        let size = self.size();
        assert!(
            !jobs.is_empty() && jobs.len().is_multiple_of(size),
            "{} jobs for {size} members",
            jobs.len()
        );
        let per = jobs.len() / size;
        let jobs: Vec<Mutex<Option<J>>> = jobs.into_iter().map(|j| Mutex::new(Some(j))).collect();
        let results: Vec<Mutex<Option<R>>> = jobs.iter().map(|_| Mutex::new(None)).collect();
        // Per member: the index of its next untaken job.
        let next: Vec<AtomicUsize> = (0..size).map(|t| AtomicUsize::new(t * per)).collect();
        self.run(&|t| {
            for owner in (0..size).map(|d| (t + d) % size) {
                loop {
                    let k = next[owner].fetch_add(1, Ordering::Relaxed);
                    if k >= (owner + 1) * per {
                        break;
                    }
                    let job = jobs[k].lock().ok().and_then(|mut j| j.take());
                    if let Some(job) = job {
                        let r = work(job);
                        if let Ok(mut slot) = results[k].lock() {
                            *slot = Some(r);
                        }
                    }
                }
            }
        });
        results
            .into_iter()
            .map(|r| r.into_inner().ok().flatten().expect("every job ran"))
            .collect()
    }

    /// Lets the helpers yield their CPUs at once instead of spinning first
    /// until the next task: call before other parallel work (rayon's) so that
    /// they do not compete with it.
    pub(super) fn rest(&self) {
        self.shared.rest.store(true, Ordering::SeqCst);
    }

    /// Unparks the helpers that parked (or are about to).
    fn wake(&self) {
        for (h, sleeping) in self.helpers.iter().zip(&self.shared.sleeping) {
            if sleeping.load(Ordering::SeqCst) {
                h.thread().unpark();
            }
        }
    }
}

impl Drop for Team {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::SeqCst);
        self.shared.generation.fetch_add(1, Ordering::SeqCst);
        self.wake();
        for h in self.helpers.drain(..) {
            // A helper catches its tasks' panics, so joining cannot fail
            // in a way there is anything left to do about.
            let _ = h.join();
        }
    }
}

/// Waits, also while unwinding, until every helper has finished the task.
struct WaitForHelpers<'a> {
    shared: &'a Shared,
    helpers: usize,
}

impl Drop for WaitForHelpers<'_> {
    fn drop(&mut self) {
        let mut wait = Patience::new(false);
        while self.shared.finished.load(Ordering::Acquire) < self.helpers {
            wait.pause();
        }
    }
}

/// Spinning, then yielding: how a thread waits for another team member.
struct Patience {
    since: Instant,
    looks: u32,
    yielding: bool,
}

impl Patience {
    /// Starts waiting, at once yielding with `yielding`.
    fn new(yielding: bool) -> Self {
        Self {
            since: Instant::now(),
            looks: 0,
            yielding,
        }
    }

    /// One pause between two looks.
    fn pause(&mut self) {
        self.looks = self.looks.wrapping_add(1);
        if !self.yielding && self.lasted(SPIN) {
            self.yielding = true;
        }
        if self.yielding {
            std::thread::yield_now();
        } else {
            std::hint::spin_loop();
        }
    }

    /// Whether the wait has lasted longer than `d` (the clock is read at
    /// every 64th look only; false at the others).
    fn lasted(&self, d: Duration) -> bool {
        self.looks.is_multiple_of(64) && self.since.elapsed() > d
    }
}

/// Helper `k` (share `k + 1`): waits for each new task, runs its share and
/// reports it done, until the team stops.
fn helper(s: &Shared, k: usize) {
    let mut seen = 0;
    loop {
        seen = wait_for_task(s, k, seen);
        if s.stop.load(Ordering::SeqCst) {
            return;
        }
        let task = *s.task.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(TaskRef(task)) = task {
            // SAFETY: `Team::run` keeps the task alive until `finished`
            // counts this helper.
            let task = unsafe { &*task };
            if let Err(payload) = catch_unwind(AssertUnwindSafe(|| task(k + 1))) {
                s.panic
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .get_or_insert(payload);
            }
        }
        s.finished.fetch_add(1, Ordering::Release);
    }
}

/// Waits (spinning, yielding, then parked) until the generation differs
/// from `seen`; returns it.
fn wait_for_task(s: &Shared, k: usize, seen: u64) -> u64 {
    let mut wait = Patience::new(s.rest.load(Ordering::Relaxed));
    loop {
        let g = s.generation.load(Ordering::Acquire);
        if g != seen {
            return g;
        }
        if s.rest.load(Ordering::Relaxed) {
            wait.yielding = true;
        }
        if !wait.lasted(PARK_AFTER) {
            wait.pause();
            continue;
        }
        // Announce the park, then look again: `run` bumps the generation
        // before it looks at `sleeping`, so one of the two sees the other.
        s.sleeping[k].store(true, Ordering::SeqCst);
        if s.generation.load(Ordering::SeqCst) == seen {
            std::thread::park();
        }
        s.sleeping[k].store(false, Ordering::SeqCst);
        wait = Patience::new(false);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_job_runs_once_and_results_keep_job_order() {
        let team = Team::new(3);
        let runs = AtomicUsize::new(0);
        for round in 0..100 {
            let jobs: Vec<usize> = (0..6).map(|j| 10 * j + round).collect();
            let out = team.for_each(jobs.clone(), |j| {
                runs.fetch_add(1, Ordering::Relaxed);
                2 * j
            });
            assert_eq!(out, jobs.iter().map(|j| 2 * j).collect::<Vec<_>>());
            if round % 10 == 0 {
                team.rest();
                std::thread::sleep(Duration::from_millis(1));
            }
        }
        assert_eq!(runs.load(Ordering::Relaxed), 600);
    }

    #[test]
    fn a_member_held_up_has_its_later_jobs_taken_over() {
        let team = Team::new(2);
        // Jobs 0 and 1 are the caller's, 2 and 3 the helper's; the helper
        // is held up in whatever job it takes first.
        let out = team.for_each(vec![0, 1, 2, 3], |j| {
            let name = std::thread::current().name().map(String::from);
            if name.as_deref() == Some("repose-team-1") {
                std::thread::sleep(Duration::from_millis(100));
            }
            (j, name)
        });
        assert_eq!(out.iter().map(|o| o.0).collect::<Vec<_>>(), [0, 1, 2, 3]);
        assert_ne!(out[3].1.as_deref(), Some("repose-team-1"), "{out:?}");
    }

    #[test]
    fn a_helper_panic_reaches_the_caller_and_the_team_stays_usable() {
        let team = Team::new(2);
        let caught = catch_unwind(AssertUnwindSafe(|| {
            team.run(&|t| {
                if t == 1 {
                    panic!("share one fails");
                }
            })
        }));
        let message = caught.expect_err("the panic is passed on");
        assert_eq!(message.downcast_ref::<&str>(), Some(&"share one fails"));
        assert_eq!(team.for_each(vec![1, 2], |j| j * 2), [2, 4]);
    }
}
