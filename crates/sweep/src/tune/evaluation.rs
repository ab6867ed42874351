//! What the search records of each configuration it renders: a leaf module, so that the
//! search (which makes evaluations) and the outputs (which write them) both depend on it
//! and not on each other.

use super::propose::Origin;

/// One configuration evaluated at one level (on every context).
#[derive(Debug, Clone)]
pub(crate) struct Evaluation {
    /// Configuration id `i<iteration>-b<bracket>-c<k>`.
    pub(crate) id: String,
    /// Hyperband iteration.
    pub(crate) iteration: u32,
    /// Bracket (its number of halvings, Hyperband's s).
    pub(crate) bracket: u32,
    /// Rung within the bracket.
    pub(crate) rung: u32,
    /// Fidelity level.
    pub(crate) level: u32,
    /// Parameter values (choices as indices).
    pub(crate) values: Vec<f64>,
    /// How it was proposed.
    pub(crate) origin: Origin,
    /// Its cells, one per context.
    pub(crate) cells: Vec<usize>,
    /// The objective: geometric mean over contexts (+∞ when a cell failed).
    pub(crate) error: f64,
    /// Render seconds per frame predicted at the target level (largest over contexts).
    pub(crate) seconds: f64,
    /// Within the time constraint.
    pub(crate) feasible: bool,
}

impl Evaluation {
    /// What ranking and the model use: the error, or +∞ when infeasible.
    pub(crate) fn loss(&self) -> f64 {
        if self.feasible {
            self.error
        } else {
            f64::INFINITY
        }
    }
}
