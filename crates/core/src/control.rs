//! How a long render reports its progress and when it must stop: a [`Control`] carries a
//! progress callback (rows or photon chunks finished) and an optional time limit, checked
//! between rows and between photon chunks, so a runaway render ends with
//! [`Error::TimeLimit`] instead of running on.

use std::time::{Duration, Instant};

use glam::Vec3;

use crate::error::{Error, Result};

fn no_progress(_: u64) {}

/// Progress callback and time limit of one render.
#[derive(Clone, Copy)]
pub struct Control<'a> {
    progress: &'a (dyn Fn(u64) + Sync),
    deadline: Option<(Instant, Duration)>,
    reference: Option<&'a [Vec3]>,
}

impl std::fmt::Debug for Control<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Control")
            .field("time_limit", &self.deadline.map(|(_, d)| d))
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
        }
    }

    /// Reports progress to `progress` (rows finished so far, per call of a pass).
    pub fn new(progress: &'a (dyn Fn(u64) + Sync)) -> Self {
        Control {
            progress,
            deadline: None,
            reference: None,
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
