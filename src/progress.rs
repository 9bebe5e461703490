//! The progress reports of the main job: the stages, a report, the callback. Below every
//! stage: the stages report through these types and never call up into the pipeline.

use std::sync::Arc;

use serde::Serialize;

/// The stage a [`Progress`] report is about, in pipeline order. [`crate::quadrangulate`] reports
/// the stages from [`Stage::Topology`] to [`Stage::Check`]; reading and writing are the
/// caller's (the command line reports them too).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
#[non_exhaustive]
pub enum Stage {
    /// Reading the input file (`done`/`total`: bytes).
    Read,
    /// Input checks, each surface's triangles, adjacency and regions, and parity repair
    /// (`done`/`total`: these four steps, weighted by their usual share of the time).
    Topology,
    /// The matching graphs and their costs (`done`/`total`: triangles of the surfaces whose
    /// graph is built, of all).
    Graph,
    /// The minimum-cost perfect matchings and the quads made from them (`done`/`total`:
    /// triangles, each surface counting its share of the solver's progress).
    Matching,
    /// Uniform refinement (`done`/`total`: levels).
    Refine,
    /// Smoothing and topological optimization (`done`/`total`: quads times the steps of
    /// the optimizer's schedule, summed over surfaces).
    Optimize,
    /// The invariant and validity checks (`done`/`total`: 0/1, then 1/1).
    Check,
    /// Writing the output file (`done`/`total`: 0/1, then 1/1).
    Write,
}

impl Stage {
    /// The stage's name in lower case, as serialized ("read", "topology", "graph",
    /// "matching", "refine", "optimize", "check", "write").
    pub fn name(self) -> &'static str {
        match self {
            Stage::Read => "read",
            Stage::Topology => "topology",
            Stage::Graph => "graph",
            Stage::Matching => "matching",
            Stage::Refine => "refine",
            Stage::Optimize => "optimize",
            Stage::Check => "check",
            Stage::Write => "write",
        }
    }
}

/// A progress report: `done` of `total` units of `stage` (see [`Stage`] for the units),
/// and for the stages that go surface by surface, how many surfaces are finished with it.
///
/// What stays true of the reports one [`crate::quadrangulate`] call sends (fallback rounds start
/// the stages again from [`Stage::Topology`]; without [`crate::Options::optimize`], a round that
/// only optimizes the surfaces whose matching left quads that are not valid starts again
/// from [`Stage::Optimize`]): within a round, stages come in [`Stage`]
/// order; within a stage `done` never decreases and `done <= total`, `total > 0`; each stage
/// a round goes through starts with a report where `done == 0` and ends with one where
/// `done == total`. Reports are throttled (a
/// few hundred per call at most, whatever the mesh size), so a callback may redraw on each.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[non_exhaustive]
pub struct Progress {
    /// The stage.
    pub stage: Stage,
    /// Units done.
    pub done: u64,
    /// Units in all (> 0).
    pub total: u64,
    /// Surfaces finished with this stage (0 for the stages that are not per surface).
    pub surfaces_done: usize,
    /// Surfaces the stage works on (0 for the stages that are not per surface).
    pub surfaces: usize,
}

impl Progress {
    /// `done` of `total` units of `stage`, no surface count (`total` 0: nothing to do, so
    /// 1 of 1).
    pub fn new(stage: Stage, done: u64, total: u64) -> Self {
        let (done, total) = if total == 0 { (1, 1) } else { (done, total) };
        Progress {
            stage,
            done: done.min(total),
            total,
            surfaces_done: 0,
            surfaces: 0,
        }
    }

    /// The same report with a surface count.
    pub fn with_surfaces(mut self, done: usize, surfaces: usize) -> Self {
        self.surfaces_done = done.min(surfaces);
        self.surfaces = surfaces;
        self
    }

    /// `done / total`, in [0, 1].
    pub fn fraction(&self) -> f64 {
        (self.done as f64 / self.total.max(1) as f64).clamp(0.0, 1.0)
    }
}

/// A progress callback, called from any thread (one call at a time).
#[derive(Clone)]
pub struct ProgressFn(pub Arc<dyn Fn(Progress) + Send + Sync>);

impl ProgressFn {
    /// A callback calling `f` with every report.
    pub fn new(f: impl Fn(Progress) + Send + Sync + 'static) -> Self {
        ProgressFn(Arc::new(f))
    }

    /// Calls the callback.
    pub fn report(&self, p: Progress) {
        (self.0)(p)
    }
}

impl std::fmt::Debug for ProgressFn {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("ProgressFn")
    }
}

impl PartialEq for ProgressFn {
    /// The same callback.
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}
