//! What [`super::quadrangulate`] did, and why it refused.

use super::*;

/// Wall time of each stage, summed over fallback rounds.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Times {
    /// Recombination (parity, graph, matching, quads, fallback splits).
    pub recombine: Duration,
    /// Refinement.
    pub refine: Duration,
    /// Optimization.
    pub optimize: Duration,
    /// Invariant and validity checks.
    pub check: Duration,
    /// Second-order nodes and their Jacobian check (second-order input only).
    pub second_order: Duration,
}

/// What [`quadrangulate`] did.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Report {
    /// The recombination of the final round.
    pub recombine: recombine::RecombineReport,
    /// One entry per refinement level.
    pub refine: Vec<refine::RefineReport>,
    /// The optimization of the final round (`None` without optimization).
    pub optimize: Option<optimize::OptimizeReport>,
    /// Fallback splits done before the final round's recombination (empty when the first
    /// run was valid).
    pub fallback: Option<recombine::FallbackSplit>,
    /// Quads the fallback priced out of the final round's matching (their triangles were
    /// paired otherwise where the matching could).
    pub priced_out: usize,
    /// Runs done (1 + fallback rounds).
    pub rounds: usize,
    /// Quads still invalid (only with [`Options::allow_invalid`]; empty otherwise).
    pub invalid: Vec<BadQuad>,
    /// The second-order step (second-order input only).
    pub second_order: Option<crate::high_order::SecondOrderReport>,
    /// The renumbering of nodes and elements to 1..N (all zero with
    /// [`Options::keep_tags`]).
    pub renumber: crate::renumber::RenumberReport,
    /// What the job did, in order, as lines in plain words (what `--verbose` prints).
    pub log: Vec<String>,
    /// What the caller may not expect (every warning is also worth showing without
    /// `--verbose`).
    pub warnings: Vec<Warning>,
    /// Wall times.
    pub times: Times,
}

/// Why [`quadrangulate`] failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Reading or writing an MSH file.
    #[error(transparent)]
    Msh(#[from] crate::msh::MshError),
    /// Recombination refused or failed.
    #[error(transparent)]
    Recombine(#[from] recombine::RecombineError),
    /// Refinement refused.
    #[error(transparent)]
    Refine(#[from] refine::RefineError),
    /// Optimization failed.
    #[error(transparent)]
    Optimize(#[from] optimize::OptimizeError),
    /// The result broke an invariant (a bug: please report it with the input).
    #[error("internal check failed after {stage}: {violation}")]
    Invariant {
        /// The stage after which the check failed.
        stage: &'static str,
        /// What failed.
        #[source]
        violation: recombine::InvariantViolation,
    },
    /// The fallback ran out of rounds without a verdict (a bug: please report it with the
    /// input).
    #[error("internal error: the fallback ended without a result")]
    FallbackExhausted,
    /// Some quads are not valid even after the fallback.
    #[error("{}", invalid_message(bad, *wrapped))]
    Invalid {
        /// The quads still bad after the last round.
        bad: Vec<BadQuad>,
        /// The rounds' log up to the refusal (what [`Report::log`] would have held).
        log: Vec<String>,
        /// A surface of those quads that the input wraps round a node, and that node (one
        /// of the quads' when it can): a surface meshed coarser than its curvature, a few
        /// triangles round, where a quad of two triangles spans too sharp a turn.
        wrapped: Option<(i32, u64)>,
    },
    /// Second-order input refused, or second-order elements not valid.
    #[error(transparent)]
    SecondOrder(crate::high_order::HighOrderError),
    /// The mesh has no surface element, so nothing to recombine: why, in words (no mesh,
    /// curves or volumes only, or a file whose physical groups hold no surface).
    #[error("{0}")]
    NothingToRecombine(String),
}

/// A refusal of the linear copy is the linear job's refusal ([`Error::Recombine`]).
impl Error {
    /// The [`Options`] field that, set to `true`, gets past this refusal
    /// (`"allow_invalid"`, `"drop_volumes"`), when one does: the front ends name it their
    /// own way (the command line as a flag, the Python package as a keyword).
    pub fn option_past(&self) -> Option<&'static str> {
        match self {
            Error::Invalid { .. }
            | Error::SecondOrder(crate::high_order::HighOrderError::Invalid { .. }) => {
                Some("allow_invalid")
            }
            Error::Recombine(recombine::RecombineError::VolumeElements { .. }) => {
                Some("drop_volumes")
            }
            _ => None,
        }
    }
}

impl From<crate::high_order::HighOrderError> for Error {
    fn from(e: crate::high_order::HighOrderError) -> Self {
        match e {
            crate::high_order::HighOrderError::Recombine(e) => Error::Recombine(e),
            e => Error::SecondOrder(e),
        }
    }
}

fn invalid_message(bad: &[BadQuad], wrapped: Option<(i32, u64)>) -> String {
    let mut m = format!(
        "{} quad(s) on surface(s) {} are not valid even after splitting their triangles into quads; first: {}",
        bad.len(),
        sorted_list(bad.iter().map(|b| &b.surface)),
        bad.first().map(|b| b.to_string()).unwrap_or_default()
    );
    if let Some((surface, node)) = wrapped {
        m += &format!(
            "; surface {surface} is meshed coarser than its curvature: at node {node} one of its triangles turns 90 degrees or more from the mean of those around the node, so a quad of two triangles spans too sharp a turn (a finer mesh there, e.g. with Mesh.MeshSizeFromCurvature, avoids it)"
        );
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::validity::Defect;

    #[test]
    fn a_refusal_on_a_wrapped_surface_says_it_is_meshed_coarser_than_its_curvature() {
        let bad = vec![BadQuad {
            surface: 3,
            element: 17,
            nodes: [5, 6, 7, 8],
            defect: Defect::Corner {
                corner: 1,
                degrees: -40.0,
            },
        }];
        let plain = invalid_message(&bad, None);
        assert!(plain.starts_with("1 quad(s) on surface(s) 3 are not valid"), "{plain}");
        assert!(!plain.contains("curvature"), "{plain}");
        let wrapped = invalid_message(&bad, Some((3, 6)));
        for w in [
            "surface 3 is meshed coarser than its curvature",
            "at node 6 one of its triangles turns 90 degrees or more",
            "Mesh.MeshSizeFromCurvature",
        ] {
            assert!(wrapped.contains(w), "{w:?} not in {wrapped}");
        }
    }
}
