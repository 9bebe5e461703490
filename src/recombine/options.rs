//! What [`super::recombine`] is asked to do.

/// What to do with surfaces that have an odd number of triangles.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ParityMode {
    /// Split boundary segments so that every surface becomes even (default).
    #[default]
    Repair,
    /// Refuse with [`RecombineError::OddParity`](super::RecombineError::OddParity).
    Error,
}

/// Options of [`recombine`](super::recombine).
#[derive(Debug, Clone, PartialEq)]
pub struct RecombineOptions {
    /// Parity handling.
    pub parity: ParityMode,
    /// Drop volume elements instead of refusing the mesh.
    pub drop_volumes: bool,
    /// Check the matching's optimality certificate and [`check_invariants`](super::check_invariants).
    pub verify: bool,
    /// Add the extra edges of section 5.3 (on by default; off only for experiments).
    pub extra_edges: bool,
    /// Weight of the cross-field alignment cost (eq. 7) added to the quality cost (eq. 4):
    /// a graph edge costs `10⁴ · (1 − η_s + w · c₇)`, the cross field following the
    /// nearest wall in graph steps (a breadth-first search from the wall edges). 0 (default)
    /// is eq. 4 alone (the CLI's default is 0.05); clamped to [0, 5]. Its measured effect is
    /// in BENCHMARKS.md, "Cross-field weight".
    pub cross_field_weight: f64,
    /// With `cross_field_weight` > 0: use the smooth (harmonic) cross field of
    /// `cross_field.rs` instead of the nearest-wall one (off by default; see GUIDE.md).
    pub harmonic_cross_field: bool,
    /// Nodes with a tag at least this are split nodes like parity repair's (the halves of a
    /// triangle split there cost [`split_halves_cost`](super::split_halves_cost) to merge back): the pipeline's
    /// fallback sets it to the first tag its edge splits used. `None`: parity splits only.
    pub split_nodes_from: Option<u64>,
    /// Quads the matching should avoid, each as its four node tags sorted: a graph edge
    /// whose two triangles form one of them costs [`priced_out_cost`](super::priced_out_cost) (three extra edges).
    /// The pipeline's fallback sets it to the quads that were not valid after
    /// optimization; tags that are not nodes, or quads no pair forms, are ignored.
    pub priced_out: Vec<[u64; 4]>,
    /// Boundary segments (their two node tags, either order) that parity repair splits only
    /// when no other segment fixes the same odd regions: the pipeline's fallback sets it to
    /// the segments whose split node ended in a quad that was not valid (the matching
    /// merged the split halves back, or paired them badly). Tags that are not nodes, or
    /// pairs that are no boundary segment, are ignored.
    pub parity_avoid: Vec<(u64, u64)>,
    /// Price the two halves of a triangle split on a straight boundary (a flat corner at
    /// the split node) above every other way out ([`split_halves_cost`](super::split_halves_cost)) instead of like
    /// those of a curved boundary ([`curved_split_halves_cost`](super::curved_split_halves_cost)): the pipeline's fallback
    /// sets it once a quad at a split node was not valid.
    pub flat_halves_out: bool,
    /// Surfaces (entity tags, sorted) where every pair with a hopeless corner at a wall
    /// node (a corner near 180° or 0° that optimization never changes,
    /// [`HOPELESS_COST`](super::HOPELESS_COST)) costs
    /// [`priced_out_cost`](super::priced_out_cost) instead, so the matching takes up to two
    /// extra edges, whose quads optimization repairs, rather than one such pair. The
    /// pipeline's fallback sets it, in the job it runs where the splits cascaded, to the
    /// surfaces where a round left a quad that is not valid.
    pub hopeless_out: Vec<i32>,
    /// New nodes inside a surface (tags, sorted) that the optimizer places: the midpoints
    /// of the radial edges of fans the pipeline's fallback peeled
    /// ([`split_triangles`](super::split_triangles)). A corner there is no wall's: a pair
    /// straight at such a node costs by its η like any other (the optimizer opens the
    /// corner), not as a hopeless pair. Tags that are not nodes are ignored.
    pub movable_nodes: Vec<u64>,
    /// Mesh again the strips (narrow faces whose triangles lie in one row between walls)
    /// whose matching's quads are poor, in cells and midlines of new nodes (on by default;
    /// see the recombination's documentation).
    pub two_row_strips: bool,
    /// Turn the ends of narrow faces one row wide whose end curve has a middle node across
    /// the side curves they share (on by default; see the recombination's step 3). Off,
    /// every curve node stays where it is and a curve segment is only split at its
    /// midpoint (parity).
    pub turn_strip_ends: bool,
    /// Where stage times and matching graphs go (see [`crate::profile`]); `None`: nowhere.
    pub trace: Option<crate::profile::Trace>,
    /// Where the progress of the stages [`crate::progress::Stage::Topology`], [`crate::progress::Stage::Graph`]
    /// and [`crate::progress::Stage::Matching`] goes (called from any thread, a few hundred times at
    /// most; a surface's solver reports from its own thread); `None`: nowhere.
    pub progress: Option<crate::progress::ProgressFn>,
    /// The caller already removed repeated triangles ([`drop_repeated_triangles`](super::drop_repeated_triangles) returned
    /// `None` or its mesh is the one given): [`recombine`](super::recombine) does not look for them again.
    pub repeated_dropped: bool,
    /// Run the fractional start of the matching of a surface of 200,000 triangles or more
    /// in blocks side by side ([`crate::Options::split_matching`]); off by default.
    pub split_matching: bool,
}

impl Default for RecombineOptions {
    fn default() -> Self {
        RecombineOptions {
            parity: ParityMode::Repair,
            drop_volumes: false,
            verify: false,
            extra_edges: true,
            cross_field_weight: 0.0,
            harmonic_cross_field: false,
            split_nodes_from: None,
            priced_out: Vec::new(),
            parity_avoid: Vec::new(),
            flat_halves_out: false,
            hopeless_out: Vec::new(),
            movable_nodes: Vec::new(),
            two_row_strips: true,
            turn_strip_ends: true,
            trace: None,
            progress: None,
            repeated_dropped: false,
            split_matching: false,
        }
    }
}
