//! What the main job tells its caller beside the result: [`Warning`]s, typed so that a
//! caller can tell them apart, each with a sentence in plain words
//! ([`std::fmt::Display`]). No sentence names a command-line flag: the command line adds
//! those where a flag is the way out.

use serde::ser::SerializeStruct;

/// Something the main job did that the caller may not expect (see [`crate::Report`]).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Warning {
    /// Triangles that repeat another triangle's nodes (zero-area pockets) were dropped
    /// before the work; `text` names them.
    RepeatedTriangles {
        /// Which triangles, in words.
        text: String,
    },
    /// The renumbering to 1..N kept some tags or data as they were; `text` says which and
    /// why.
    Renumbering {
        /// What was kept, in words.
        text: String,
    },
    /// Quads written although they are not valid (only when invalid quads are allowed).
    InvalidQuads {
        /// How many.
        count: usize,
        /// The quads and what is wrong with each, in words.
        list: String,
    },
    /// A surface meshed coarser than its curvature (at `node` one of its triangles turns 90
    /// degrees or more from the mean of those around it): no pair of triangles there made a
    /// valid quad, and the fallback split triangles there into three quads each.
    CoarseSurface {
        /// The surface entity's tag.
        surface: i32,
        /// A node the surface wraps round, of a split triangle.
        node: u64,
    },
    /// Quads with η (eq. 3) under 0.2 left where the input's corners allow better (the
    /// smallest angle the surface's triangles make at a boundary node is above the quad's
    /// η times 90°): the run made no better quads there within the element-count rule
    /// (the worst-quad tries, where they ran, kept none that raised them), as where the
    /// input's triangles pair only into such quads (a narrow face one triangle wide whose
    /// ends force every pair to straddle two cells). Not given for the surfaces of a
    /// [`Warning::CoarseSurface`].
    PoorQuads {
        /// How many quads under η 0.2.
        count: usize,
        /// Their surfaces' tags, increasing.
        surfaces: Vec<i32>,
        /// The worst of them.
        eta_w: f64,
    },
    /// Boundary fans peeled on surfaces whose curves are meshed much finer than the face
    /// beside them (runs of triangles each with a segment on a curve and one apex inside),
    /// and the result above the element-count rule: a valid quad holds at most one segment
    /// where a curve runs straight, so each such triangle became a quad on the curve and a
    /// triangle at the apex.
    FineCurves {
        /// The surfaces with peeled triangles, increasing.
        surfaces: Vec<i32>,
        /// Triangles peeled.
        peeled: usize,
        /// New quads per input triangle (before refinement).
        quads_per_triangle: f64,
    },
    /// Second-order elements written although their Jacobian is not positive everywhere
    /// (only when invalid elements are allowed).
    InvalidSecondOrder {
        /// How many.
        count: usize,
        /// The elements, in words.
        list: String,
    },
}

impl Warning {
    /// A short name of the kind, in snake case (`"invalid_quads"`), as the JSON report
    /// gives it.
    pub fn kind(&self) -> &'static str {
        match self {
            Warning::RepeatedTriangles { .. } => "repeated_triangles",
            Warning::Renumbering { .. } => "renumbering",
            Warning::InvalidQuads { .. } => "invalid_quads",
            Warning::CoarseSurface { .. } => "coarse_surface",
            Warning::PoorQuads { .. } => "poor_quads",
            Warning::FineCurves { .. } => "fine_curves",
            Warning::InvalidSecondOrder { .. } => "invalid_second_order",
        }
    }

    /// True for the warnings that only come when invalid elements are allowed.
    pub fn is_invalid_written(&self) -> bool {
        matches!(
            self,
            Warning::InvalidQuads { .. } | Warning::InvalidSecondOrder { .. }
        )
    }
}

impl std::fmt::Display for Warning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Warning::RepeatedTriangles { text } | Warning::Renumbering { text } => {
                f.write_str(text)
            }
            Warning::InvalidQuads { count, list } => {
                write!(f, "writing {count} invalid quad(s): {list}")
            }
            Warning::CoarseSurface { surface, node } => write!(
                f,
                "surface {surface} is meshed coarser than its curvature: at input node {node} one of its triangles turns 90 degrees or more from the mean of those around the node, so no pair of triangles there makes a valid quad, and its triangles there were split into three quads each (a finer mesh there, e.g. with Mesh.MeshSizeFromCurvature, gives fewer and better quads)"
            ),
            Warning::PoorQuads {
                count,
                surfaces,
                eta_w,
            } => {
                let list: Vec<String> = surfaces.iter().map(i32::to_string).collect();
                write!(
                    f,
                    "{count} quad(s) with eta under 0.2 (worst {eta_w:.3}) on surface(s) {}, though the input's corners there allow better: the run made no better quads there at about one quad per two triangles (a finer or more regular mesh there, e.g. more nodes across a narrow face, gives better quads)",
                    list.join(", ")
                )
            }
            Warning::FineCurves {
                surfaces,
                peeled,
                quads_per_triangle,
            } => {
                let list: Vec<String> = surfaces.iter().map(i32::to_string).collect();
                write!(
                    f,
                    "surface(s) {} are meshed much finer along their curves than inside: {peeled} triangle(s) with a segment on a curve share their apex with the next, and a valid quad holds only one segment where a curve runs straight, so each became a quad on the curve and a triangle at the apex, {quads_per_triangle:.2} new quads per input triangle in all (sizes that grow more gently away from the curves give about one quad per two triangles)",
                    list.join(", ")
                )
            }
            Warning::InvalidSecondOrder { count, list } => write!(
                f,
                "writing {count} second-order element(s) whose Jacobian is not positive everywhere: {list}"
            ),
        }
    }
}

/// `{"kind": ..., "message": ...}`.
impl serde::Serialize for Warning {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut st = s.serialize_struct("Warning", 2)?;
        st.serialize_field("kind", self.kind())?;
        st.serialize_field("message", &self.to_string())?;
        st.end()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_warning_is_a_sentence_without_flags_and_a_kind_in_json() {
        let w = Warning::InvalidQuads {
            count: 2,
            list: "surface 1, quad 3".into(),
        };
        assert_eq!(
            w.to_string(),
            "writing 2 invalid quad(s): surface 1, quad 3"
        );
        assert!(w.is_invalid_written());
        let json = serde_json::to_string(&w).expect("json");
        assert_eq!(
            json,
            r#"{"kind":"invalid_quads","message":"writing 2 invalid quad(s): surface 1, quad 3"}"#
        );
        let r = Warning::Renumbering {
            text: "node tags kept".into(),
        };
        assert!(!r.is_invalid_written());
        assert_eq!(r.to_string(), "node tags kept");
        let fine = Warning::FineCurves {
            surfaces: vec![1, 2],
            peeled: 116,
            quads_per_triangle: 0.651,
        };
        assert_eq!(fine.kind(), "fine_curves");
        let text = fine.to_string();
        assert!(
            text.starts_with("surface(s) 1, 2 are meshed much finer along their curves")
                && text.contains("116 triangle(s)")
                && text.contains("0.65 new quads per input triangle"),
            "{text}"
        );
        assert!(!fine.is_invalid_written());
        let c = Warning::CoarseSurface {
            surface: 4,
            node: 17,
        };
        assert_eq!(c.kind(), "coarse_surface");
        assert!(!c.is_invalid_written());
        let text = c.to_string();
        assert!(
            text.starts_with("surface 4 is meshed coarser than its curvature: at input node 17"),
            "{text}"
        );
        assert!(!text.contains("--"), "{text}");
        let p = Warning::PoorQuads {
            count: 3,
            surfaces: vec![2, 5],
            eta_w: 0.0514,
        };
        assert_eq!(p.kind(), "poor_quads");
        assert!(!p.is_invalid_written());
        let text = p.to_string();
        assert!(
            text.starts_with("3 quad(s) with eta under 0.2 (worst 0.051) on surface(s) 2, 5, "),
            "{text}"
        );
        assert!(!text.contains("--"), "{text}");
    }
}
