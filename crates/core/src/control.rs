//! How a long render reports its progress and when it must stop: a [`Control`] carries a
//! progress callback (rows or photon chunks finished) and an optional time limit, checked
//! between rows and between photon chunks, so a runaway render ends with
//! [`Error::TimeLimit`] instead of running on. A reference pass given a [`Counting`]
//! ([`Control::with_counting`]) also counts its work there.

use std::time::{Duration, Instant};

use glam::Vec3;

use crate::counters::Counting;
use crate::error::{Error, Result};

fn no_progress(_: u64) {}

/// Progress callback and time limit of one render.
#[derive(Clone, Copy)]
pub struct Control<'a> {
    progress: &'a (dyn Fn(u64) + Sync),
    deadline: Option<(Instant, Duration)>,
    reference: Option<&'a [Vec3]>,
    error_probes: bool,
    counting: Option<&'a Counting>,
}

impl std::fmt::Debug for Control<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Control")
            .field("time_limit", &self.deadline.map(|(_, d)| d))
            .field("error_probes", &self.error_probes)
            .field("counting", &self.counting.is_some())
            .finish()
    }
}

impl Default for Control<'_> {
    fn default() -> Self {
        Control::none()
    }
}

impl<'a> Control<'a> {
    /// No progress reports, no time limit.
    pub const fn none() -> Control<'static> {
        Control {
            progress: &no_progress,
            deadline: None,
            reference: None,
            error_probes: true,
            counting: None,
        }
    }

    /// Reports progress to `progress` (rows finished so far, per call of a pass).
    pub fn new(progress: &'a (dyn Fn(u64) + Sync)) -> Self {
        Control {
            progress,
            deadline: None,
            reference: None,
            error_probes: true,
            counting: None,
        }
    }

    /// The converged image this render is measured against (its displayed layers, the
    /// camera's size): a progressive render records its error per iteration and stops at
    /// `integrator.target_rmse`.
    pub fn with_reference(mut self, reference: &'a [Vec3]) -> Self {
        self.reference = Some(reference);
        self
    }

    /// The reference image, if one was given.
    pub fn reference(&self) -> Option<&'a [Vec3]> {
        self.reference
    }

    /// Skips the pass that measures what thinning and the caches err by (the probe pixels
    /// traced again with every sample evaluated, `RenderRecord::cache_error`): a fixed cost
    /// of up to 32 × 32 × 2 eye rays that a pilot render timing the per-pixel cost must
    /// leave out (`sweep plan`). The image is the same; the record has no error bounds.
    pub fn without_error_probes(mut self) -> Self {
        self.error_probes = false;
        self
    }

    /// Whether the render measures its thinning and cache errors (the default).
    pub(crate) fn error_probes(&self) -> bool {
        self.error_probes
    }

    /// Counts the work of every reference pass of this render into `counting` (collisions,
    /// density lookups, majorant bricks, shadow rays: [`crate::Counter`]). Off by default;
    /// a counted pass renders the same bits.
    pub fn with_counting(mut self, counting: &'a Counting) -> Self {
        self.counting = Some(counting);
        self
    }

    /// Where this render's passes count their work, if anywhere.
    pub(crate) fn counting(&self) -> Option<&'a Counting> {
        self.counting
    }

    /// Stops the render with [`Error::TimeLimit`] once `limit` has passed from now.
    pub fn with_time_limit(mut self, limit: Duration) -> Self {
        self.deadline = Some((Instant::now() + limit, limit));
        self
    }

    /// Reports that `rows` rows (or units) are finished.
    /// The same time limit with another progress callback (a pass inside a longer render
    /// reports its rows offset by the work before it).
    pub(crate) fn with_progress<'b>(&self, progress: &'b (dyn Fn(u64) + Sync)) -> Control<'b>
    where
        'a: 'b,
    {
        Control {
            progress,
            deadline: self.deadline,
            reference: self.reference,
            error_probes: self.error_probes,
            counting: self.counting,
        }
    }

    #[inline]
    pub(crate) fn report(&self, rows: u64) {
        (self.progress)(rows);
    }

    /// Whether the time limit has passed (work should stop at the next boundary).
    #[inline]
    pub(crate) fn expired(&self) -> bool {
        self.deadline.is_some_and(|(at, _)| Instant::now() >= at)
    }

    /// `Err(TimeLimit)` once the time limit has passed.
    pub fn check(&self) -> Result<()> {
        match self.deadline {
            Some((at, limit)) if Instant::now() >= at => Err(Error::TimeLimit {
                seconds: limit.as_secs_f64(),
            }),
            _ => Ok(()),
        }
    }
}
