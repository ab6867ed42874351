//! Work counters of a reference pass: how many null and real collisions,
//! ratio-tracking steps, density lookups, majorant bricks and shadow rays a pass takes, so
//! that each route to a cheaper pass is explained by the run that times it
//! (`sweep bench --reference --counters`).
//!
//! Counting is off unless the pass's [`Control`](crate::Control) carries a [`Counting`]
//! ([`Control::with_counting`](crate::Control::with_counting)). A counted pass switches its
//! worker thread's tally on for each row it traces ([`Tallying`]) and adds the row's counts
//! to the [`Counting`] once, when the rows are summed at the end of the pass: the hot loops
//! touch a thread-local `Cell` (never an atomic), and with counting off they only test the
//! thread's switch. The collision loop keeps a walk's counts in locals and adds them once
//! when the walk ends ([`WalkCounts`]), so its inner loop does not touch the thread-local
//! at all.
//!
//! Counting draws no random number and changes no value: a counted pass renders the same
//! bits, and the counts are sums of integers, the same on any number of threads.

use std::cell::Cell;
use std::sync::Mutex;

/// What a counted pass counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Counter {
    /// Paths traced (samples; the weighted tracker's pilot is not counted).
    Samples,
    /// Delta-tracking walks: eye rays and the rays between vertices that met the medium.
    FreePathWalks,
    /// Delta tracking's tentative collisions rejected as null (`ξ·σ_maj ≥ σt`).
    NullCollisions,
    /// Delta tracking's real collisions (each ends its walk).
    RealCollisions,
    /// Ratio tracking's tentative collisions (each one density lookup and one factor).
    RatioSteps,
    /// Exponential steps that left their majorant brick: a draw and a logarithm that placed
    /// no collision (the collision loop draws afresh in every non-empty brick).
    Overshoots,
    /// Majorant bricks the collision loop stepped through, empty ones included.
    BricksStepped,
    /// Of those, the bricks with σ_maj = 0 (crossed without a draw).
    EmptyBricks,
    /// Density lookups of the trackers: one at each tentative collision (delta and ratio
    /// tracking), two at each vertex that collects emission. Counted where the trackers make
    /// them, not in [`crate::Medium`]'s point queries, which every integrator calls.
    DensityLookups,
    /// Albedos the trackers ask at a vertex of a medium coloured by its transfer function
    /// (three colour grids each; 0 in a grey medium, whose albedo is a constant).
    ColourLookups,
    /// Shadow rays: transmittances to a light, by any estimator (those that miss the
    /// medium included).
    ShadowRays,
}

impl Counter {
    /// How many counters there are.
    pub const COUNT: usize = 11;

    /// Every counter, in the order reports list them.
    pub const ALL: [Counter; Counter::COUNT] = [
        Counter::Samples,
        Counter::FreePathWalks,
        Counter::NullCollisions,
        Counter::RealCollisions,
        Counter::RatioSteps,
        Counter::Overshoots,
        Counter::BricksStepped,
        Counter::EmptyBricks,
        Counter::DensityLookups,
        Counter::ColourLookups,
        Counter::ShadowRays,
    ];

    /// The counter's name in reports and JSON.
    pub fn name(self) -> &'static str {
        match self {
            Counter::Samples => "samples",
            Counter::FreePathWalks => "free_path_walks",
            Counter::NullCollisions => "null_collisions",
            Counter::RealCollisions => "real_collisions",
            Counter::RatioSteps => "ratio_steps",
            Counter::Overshoots => "overshoots",
            Counter::BricksStepped => "bricks_stepped",
            Counter::EmptyBricks => "empty_bricks",
            Counter::DensityLookups => "density_lookups",
            Counter::ColourLookups => "colour_lookups",
            Counter::ShadowRays => "shadow_rays",
        }
    }
}

/// A count for every [`Counter`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counts([u64; Counter::COUNT]);

impl Counts {
    /// The count of `counter`.
    pub fn get(&self, counter: Counter) -> u64 {
        self.0[counter as usize]
    }

    /// Every counter with its count, in [`Counter::ALL`]'s order.
    pub fn iter(&self) -> impl Iterator<Item = (Counter, u64)> + '_ {
        Counter::ALL.into_iter().map(move |c| (c, self.get(c)))
    }
}

impl std::ops::AddAssign for Counts {
    fn add_assign(&mut self, other: Counts) {
        for (a, b) in self.0.iter_mut().zip(other.0) {
            *a += b;
        }
    }
}

impl std::ops::Add for Counts {
    type Output = Counts;

    fn add(mut self, other: Counts) -> Counts {
        self += other;
        self
    }
}

/// Where counted passes add their counts: a pass given one through
/// [`Control::with_counting`](crate::Control::with_counting) counts its work and adds it
/// here when it ends; [`Self::total`] reads the sum of every pass so far.
#[derive(Debug, Default)]
pub struct Counting {
    total: Mutex<Counts>,
}

impl Counting {
    /// Nothing counted yet.
    pub fn new() -> Self {
        Counting::default()
    }

    /// The counts of every pass that counted here.
    pub fn total(&self) -> Counts {
        *self.total.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Adds a pass's counts (once a pass: no lock in any loop).
    pub(crate) fn add(&self, counts: Counts) {
        *self.total.lock().unwrap_or_else(|e| e.into_inner()) += counts;
    }
}

/// One thread's tally: its switch and a count per counter.
struct Tally {
    on: Cell<bool>,
    counts: [Cell<u64>; Counter::COUNT],
}

thread_local! {
    static TALLY: Tally = const {
        Tally {
            on: Cell::new(false),
            counts: [const { Cell::new(0) }; Counter::COUNT],
        }
    };
}

/// Adds `n` to `counter` on this thread when its tally is on (a test of the switch when
/// it is off).
#[inline]
pub(crate) fn add(counter: Counter, n: u64) {
    add_each([(counter, n)]);
}

/// Counts one `counter` ([`add`]).
#[inline]
pub(crate) fn count(counter: Counter) {
    add(counter, 1);
}

/// Adds several counts with one test of the switch.
#[inline]
pub(crate) fn add_each<const N: usize>(counts: [(Counter, u64); N]) {
    TALLY.with(|t| {
        if t.on.get() {
            for (counter, n) in counts {
                let c = &t.counts[counter as usize];
                c.set(c.get() + n);
            }
        }
    });
}

/// Adds a delta-tracking walk that sampled `tentative` tentative collisions, the last of
/// them real when `real` (its density lookups are the caller's to count).
#[inline]
pub(crate) fn delta_walk(tentative: u32, real: bool) {
    let real = u64::from(real);
    add_each([
        (Counter::FreePathWalks, 1),
        (Counter::RealCollisions, real),
        (Counter::NullCollisions, u64::from(tentative) - real),
    ]);
}

/// One walk of the collision loop's counts, kept in locals while it walks and added to
/// the thread's tally once at its end ([`Self::add`]).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct WalkCounts {
    /// Majorant bricks stepped through.
    pub(crate) bricks: u32,
    /// Of those, empty ones.
    pub(crate) empty: u32,
    /// Exponential steps that left their brick.
    pub(crate) overshoots: u32,
}

impl WalkCounts {
    /// Adds the walk's counts to this thread's tally.
    #[inline]
    pub(crate) fn add(self) {
        add_each([
            (Counter::BricksStepped, u64::from(self.bricks)),
            (Counter::EmptyBricks, u64::from(self.empty)),
            (Counter::Overshoots, u64::from(self.overshoots)),
        ]);
    }
}

/// This thread's tally switched on, from zero, for a stretch of work (a row of a pass)
/// when counting; [`Self::finish`] returns what it counted, and the tally is switched off
/// again when it finishes or is dropped (an unwinding row leaves no switch on). Stretches
/// do not nest: a row traces its paths on its own thread, start to end.
#[derive(Debug)]
pub(crate) struct Tallying {
    on: bool,
}

impl Tallying {
    /// Starts counting on this thread when `on` (otherwise counts nothing).
    pub(crate) fn start(on: bool) -> Self {
        if on {
            TALLY.with(|t| {
                for c in &t.counts {
                    c.set(0);
                }
                t.on.set(true);
            });
        }
        Tallying { on }
    }

    /// What this thread counted since [`Self::start`] (nothing when not counting).
    pub(crate) fn finish(self) -> Counts {
        let mut out = Counts::default();
        if self.on {
            TALLY.with(|t| {
                for (o, c) in out.0.iter_mut().zip(&t.counts) {
                    *o = c.get();
                }
            });
        }
        out
    }
}

impl Drop for Tallying {
    fn drop(&mut self) {
        if self.on {
            // `try_with`: a thread being torn down has no tally left to switch off.
            let _ = TALLY.try_with(|t| t.on.set(false));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_thread_counts_only_inside_a_counting_stretch() {
        count(Counter::Samples);
        let off = Tallying::start(false);
        count(Counter::Samples);
        assert_eq!(off.finish(), Counts::default());
        let on = Tallying::start(true);
        count(Counter::Samples);
        add(Counter::DensityLookups, 5);
        delta_walk(3, true);
        WalkCounts {
            bricks: 4,
            empty: 1,
            overshoots: 2,
        }
        .add();
        let counts = on.finish();
        let expected = [
            (Counter::Samples, 1),
            (Counter::FreePathWalks, 1),
            (Counter::NullCollisions, 2),
            (Counter::RealCollisions, 1),
            (Counter::RatioSteps, 0),
            (Counter::Overshoots, 2),
            (Counter::BricksStepped, 4),
            (Counter::EmptyBricks, 1),
            (Counter::DensityLookups, 5),
            (Counter::ColourLookups, 0),
            (Counter::ShadowRays, 0),
        ];
        assert_eq!(counts.iter().collect::<Vec<_>>(), expected);
        // Switched off again: nothing more is counted, and a new stretch starts from zero.
        count(Counter::Samples);
        let again = Tallying::start(true);
        assert_eq!(again.finish(), Counts::default());
    }

    #[test]
    fn every_counter_is_listed_once_in_its_place() {
        for (i, c) in Counter::ALL.iter().enumerate() {
            assert_eq!(*c as usize, i, "{c:?}");
        }
        let mut names: Vec<_> = Counter::ALL.iter().map(|c| c.name()).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), Counter::COUNT);
    }

    #[test]
    fn counts_add_counter_by_counter() {
        let on = Tallying::start(true);
        count(Counter::ShadowRays);
        let a = on.finish();
        let sum = a + a;
        assert_eq!(sum.get(Counter::ShadowRays), 2);
        let counting = Counting::new();
        counting.add(a);
        counting.add(sum);
        assert_eq!(counting.total().get(Counter::ShadowRays), 3);
    }
}
