//! What [`super::recombine`] did: per surface, the parity splits, the folds walled off.

use super::*;

/// One parity split.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct ParitySplit {
    /// The curve that was split, when known.
    pub curve: Option<i32>,
    /// Surfaces whose triangle count changed parity.
    pub surfaces: Vec<i32>,
    /// Node tags of the split segment.
    pub segment: (u64, u64),
    /// Tag of the new midpoint node.
    pub new_node: u64,
    /// True when the split is the node where the ends of two narrow faces turn across the
    /// curve they share (the recombination's step 3): near the segment's end rather than at
    /// its midpoint, and not a repair of an odd surface.
    pub turn: bool,
}

/// Figures for one surface.
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize)]
pub struct SurfaceReport {
    /// Surface entity tag.
    pub surface: i32,
    /// Triangles recombined (after parity splits).
    pub triangles_in: usize,
    /// Quads produced.
    pub quads_out: usize,
    /// Quads that were already present and kept.
    pub quads_kept: usize,
    /// Parity splits that touched this surface.
    pub parity_splits: usize,
    /// Graph edges (real).
    pub graph_edges: usize,
    /// Extra edges added to the graph.
    pub extra_edges_added: usize,
    /// Extra edges in the optimal matching.
    pub extra_edges_used: usize,
    /// Edge swaps done (5.3.1).
    pub edge_swaps: usize,
    /// Vertex duplications done (5.3.2).
    pub vertex_duplications: usize,
    /// Strips meshed again in cells and midlines (a narrow face whose matching's quads
    /// were poor; see the recombination's documentation).
    pub strips_remeshed: usize,
    /// Matching cost in units of 10⁻⁴ (extra edges included).
    pub matching_cost: i64,
    /// Graph edges priced out (by the fallback).
    pub pairs_priced_out: usize,
    /// Of those, the ones the optimal matching still uses.
    pub priced_out_used: usize,
    /// Time to build topology and graph.
    pub time_graph: Duration,
    /// Time in the matching solver (and certificate check).
    pub time_matching: Duration,
    /// Time to build the quads.
    pub time_post: Duration,
}

/// What the recombination did.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct RecombineReport {
    /// One entry per surface that had triangles, by surface tag.
    pub surfaces: Vec<SurfaceReport>,
    /// Parity splits done.
    pub parity_splits: Vec<ParitySplit>,
    /// Mixed surfaces whose triangles were enclosed by quads (could not be made even or
    /// matched): their quads were split into triangles and the whole surface recombined.
    pub retriangulated: Vec<i32>,
    /// Volume elements dropped (with [`Options::drop_volumes`](crate::Options::drop_volumes)).
    pub dropped_volume_elements: usize,
    /// Surfaces whose triangles fold over each other somewhere (opposite normals across an
    /// edge): the folded edges were walled off (no quad across them), and this is the
    /// first fold of each, as [`WalledFold::refusal`] reports it when the surface's quads
    /// are not valid.
    pub walled_folds: Vec<WalledFold>,
    /// Human-readable log lines.
    pub log: Vec<String>,
    /// What the caller may not expect (triangles dropped).
    pub warnings: Vec<crate::Warning>,
    /// Total wall time.
    pub time_total: Duration,
}

/// The first fold of a surface's triangles (two triangles with opposite normals across an
/// edge), walled off by the topology instead of refused.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct WalledFold {
    /// Surface entity tag.
    pub surface: i32,
    /// Element tag of the folded triangle.
    pub element: u64,
    /// The fold in words (the triangles and their common edge).
    pub problem: String,
    /// Tags of the nodes of the surface's folded edges (graph edges made walls): they
    /// bound the walls, so a result that moved one of them is not kept.
    pub nodes: Vec<u64>,
}

impl WalledFold {
    /// The refusal naming the fold: what a surface whose quads cannot all be made valid
    /// with its folds walled off fails with.
    pub fn refusal(&self) -> RecombineError {
        RecombineError::InvalidElement {
            surface: self.surface,
            element: self.element,
            problem: self.problem.clone(),
        }
    }
}

/// Records the folds of `work` in `report` (each surface once), with a log line each.
pub(super) fn note_folds(work: &[SurfaceWork], report: &mut RecombineReport) {
    for w in work {
        let Some((
            RecombineError::InvalidElement {
                surface,
                element,
                problem,
            },
            nodes,
        )) = &w.fold
        else {
            continue;
        };
        if report.walled_folds.iter().any(|f| f.surface == *surface) {
            continue;
        }
        report.log.push(format!(
            "surface {surface}, element {element}: {problem}; the folded edges are walled off (no quad across them)"
        ));
        report.walled_folds.push(WalledFold {
            surface: *surface,
            element: *element,
            problem: problem.clone(),
            nodes: nodes.clone(),
        });
    }
}
