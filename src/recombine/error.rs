//! Why [`super::recombine`] refused or failed, in words that name the file's entities.

use super::*;

/// Why the recombination refused or failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum RecombineError {
    /// Volume elements are present (recombining their boundary would break conformity).
    #[error("the mesh has {count} volume elements (volumes {}); recombining surfaces would make them non-conforming; drop them to recombine the surfaces alone", list_tags(.volumes))]
    VolumeElements {
        /// Number of volume elements.
        count: usize,
        /// Their volume entity tags.
        volumes: Vec<i32>,
    },
    /// Surface elements that are neither 3-node triangles nor 4-node quads.
    #[error("surface {surface} has {count} elements of type {element_type} (supported: 3-node triangles and 4-node quads, or 6-node triangles alone; mesh with Mesh.ElementOrder = 1 or 2)")]
    UnsupportedSurfaceElements {
        /// Surface entity tag.
        surface: i32,
        /// Gmsh element type code.
        element_type: u32,
        /// How many.
        count: usize,
    },
    /// A periodic surface whose mesh is not the image of its master's.
    #[error("surface {surface} is periodic (a copy of surface {master} in the $Periodic section) but {reason}, so its master's quads cannot be copied onto it; remesh it with Gmsh's periodic meshing (`Periodic Surface` or `gmsh.model.mesh.setPeriodic`)")]
    PeriodicSurface {
        /// The slave surface.
        surface: i32,
        /// Its master surface.
        master: i32,
        /// What does not match, in plain words.
        reason: String,
    },
    /// An element block whose node list does not match its element count (a bug in whatever
    /// built the mesh).
    #[error("element block of type {element_type} on entity ({dim}, {entity}) has {nodes} node tags for {elements} elements")]
    MalformedBlock {
        /// Entity dimension.
        dim: i32,
        /// Entity tag.
        entity: i32,
        /// Element type.
        element_type: u32,
        /// Node tags in the block.
        nodes: usize,
        /// Elements in the block.
        elements: usize,
    },
    /// A surface element no recombination can turn into valid quads (a repeated node, a
    /// non-finite or overflowing coordinate, zero area, a non-manifold edge, an
    /// inconsistent orientation, a fold).
    #[error("surface {surface}, element {element}: {problem}; the surface cannot be recombined into valid quads")]
    InvalidElement {
        /// Surface entity tag.
        surface: i32,
        /// Element tag.
        element: u64,
        /// What is wrong, in words.
        problem: String,
    },
    /// A node or element tag so large that the tags recombination gives new nodes and
    /// elements (above the largest) would overflow.
    #[error("{what} tag {tag} is too large: recombination numbers its new {what}s above the largest tag, and tags up to {max} are supported")]
    TagTooLarge {
        /// "node" or "element".
        what: &'static str,
        /// The tag.
        tag: u64,
        /// The largest supported tag.
        max: u64,
    },
    /// An element refers to a node that does not exist.
    #[error(
        "element {element} on entity ({dim}, {entity}) refers to node {node}, which does not exist"
    )]
    UnknownNode {
        /// Entity dimension.
        dim: i32,
        /// Entity tag.
        entity: i32,
        /// Element tag.
        element: u64,
        /// Missing node tag.
        node: u64,
    },
    /// Odd surfaces with [`ParityMode::Error`].
    #[error("{message}")]
    OddParity {
        /// The odd regions.
        regions: Vec<OddRegion>,
        /// Curves whose node counts should change (`None`: a boundary without curve data).
        curves: Vec<Option<i32>>,
        /// The full explanation.
        message: String,
    },
    /// Odd regions that no combination of segment splits can fix.
    #[error("{message}")]
    ParityUnsolvable {
        /// The regions.
        regions: Vec<OddRegion>,
        /// The explanation, in plain words.
        message: String,
    },
    /// No perfect matching even with extra edges.
    #[error("surface {surface}: no perfect matching of its {triangles} triangles even with extra edges (Tutte witness: removing {witness} triangles leaves {odd_components} odd components); the triangulation cannot be recombined into quads as is")]
    NoPerfectMatching {
        /// Surface tag.
        surface: i32,
        /// Triangles in the surface.
        triangles: usize,
        /// Size of the Tutte set.
        witness: usize,
        /// Number of odd components.
        odd_components: usize,
    },
    /// Edge swap / vertex duplication could not build quads.
    #[error("surface {surface}: extra-edge post-processing failed: {detail}")]
    PostProcess {
        /// Surface tag.
        surface: i32,
        /// What went wrong.
        detail: String,
    },
    /// The matching's optimality certificate failed (a solver bug).
    #[error("surface {surface}: matching certificate check failed: {detail}")]
    Certificate {
        /// Surface tag.
        surface: i32,
        /// What failed.
        detail: String,
    },
    /// The invariant check failed after recombination.
    #[error("invariant check failed: {0}")]
    Invariant(#[source] InvariantViolation),
}

/// `1, 2, 3`: entity tags for messages.
pub(crate) fn list_tags(tags: &[i32]) -> String {
    tags.iter()
        .map(|t| t.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

pub(super) fn odd_parity_error(plan: &parity::Plan) -> RecombineError {
    // the curves the repair would split (with the periodic images and quad strips it
    // splits along): the same plan, so the advice and the repair agree
    let mut curves: Vec<Option<i32>> = plan
        .choices
        .iter()
        .flat_map(|c| std::iter::once(c.curve).chain(c.with.iter().filter_map(|w| w.2.map(Some))))
        .collect();
    curves.sort_unstable();
    curves.dedup();
    let mut msg = String::from(
        "surfaces with an odd number of triangles cannot be recombined into quads only:\n",
    );
    for o in &plan.odd {
        msg.push_str(&format!(
            "  surface {}{}: {} triangles\n",
            o.surface,
            parity::region_note(o),
            o.triangles
        ));
    }
    let named: Vec<String> = curves.iter().flatten().map(|c| c.to_string()).collect();
    if !plan.unsolved.is_empty() {
        msg.push_str(&parity::unsolvable_message(&plan.unsolved, &plan.isolated));
        msg.push('\n');
    }
    if !named.is_empty() {
        msg.push_str(&format!(
            "changing the number of nodes on curve(s) {} by one fixes {}\n",
            named.join(", "),
            if plan.unsolved.is_empty() {
                "them"
            } else {
                "the others"
            }
        ));
    }
    if curves.contains(&None) {
        msg.push_str("some odd surfaces have boundaries without curve data (no line elements)\n");
    }
    msg.push_str(
        "fix in the .geo: give every curve an odd number of nodes (e.g. `Transfinite Curve{...} = 11;`), \
         or mesh with `Mesh.RecombineAll = 1;` and `Mesh.RecombinationAlgorithm = 1;` (Gmsh then meshes curves \
         with odd node counts), or rerun with parity repair (the default), which splits one boundary segment per curve above",
    );
    RecombineError::OddParity {
        regions: plan.odd.clone(),
        curves,
        message: msg,
    }
}
