//! [`solve`](super::solve) with the pipeline's choices: progress reports, the edge list
//! moved in, the solver's vertex order.

use super::{blossom, prepare, Matching, NoPerfectMatching};

/// [`solve`](super::solve) reporting its progress to `progress` as `(done, total)`: `total`
/// fixed, `done` growing, a few dozen calls per solve at most, from the calling thread (see
/// [`blossom::Solver::set_progress`]).
#[cfg(feature = "testing")]
pub fn solve_with_progress(
    n: usize,
    edges: &[(u32, u32, i64)],
    progress: blossom::ProgressCallback,
) -> Result<Matching, NoPerfectMatching> {
    prepare(n, edges, Some(progress), VertexOrder::BreadthFirst)?.run()
}

/// [`solve`](super::solve) with the edge list moved in (and the progress of
/// `solve_with_progress` when given): the list is freed as soon as the solver has built its own arrays from it, so
/// that it is not live through the solve. `order` is the solver's internal vertex
/// numbering ([`VertexOrder`]); the result is the same optimum in the caller's numbering
/// either way (among tied optima, possibly another one). `split`: `Some(release)` runs the
/// fractional start of a large graph in blocks side by side, `release` handing the memory
/// freed before them back to the system ([`blossom::Solver::set_split`]).
pub fn solve_owned(
    n: usize,
    edges: Vec<(u32, u32, i64)>,
    progress: Option<blossom::ProgressCallback>,
    order: VertexOrder,
    split: Option<fn()>,
) -> Result<Matching, NoPerfectMatching> {
    let mut solver = prepare(n, &edges, progress, order)?;
    drop(edges);
    solver.set_split(split.is_some(), split);
    solver.run()
}

/// The solver's internal numbering of the vertices, for memory locality: its searches
/// visit a vertex's neighbours, so neighbours with nearby numbers share cache lines.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum VertexOrder {
    /// Breadth-first, component by component from the lowest unvisited vertex: local on
    /// any connected sparse graph, whatever its numbering (the default).
    #[default]
    BreadthFirst,
    /// The caller's numbering, for graphs numbered along a space-filling curve (mesh
    /// triangles in the Morton order of their centroids): neighbours are then closer than
    /// breadth-first layers put them (figures in BENCHMARKS.md, "Measurements behind the
    /// defaults").
    Given,
}
