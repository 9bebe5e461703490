//! Topological operators (to come).
use super::local::Local;
use super::OperationCounts;

/// One pass of the operators; returns how many were applied.
pub(crate) fn pass(_l: &mut Local, _ops: &mut OperationCounts) -> usize {
    0
}
