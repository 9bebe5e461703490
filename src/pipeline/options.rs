//! What [`super::quadrangulate`] is asked to do.

use super::*;

/// Options of [`quadrangulate`]; the defaults are the command line's.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(default)]
#[non_exhaustive]
pub struct Options {
    /// What to do with surfaces that have an odd number of triangles.
    pub parity: recombine::ParityMode,
    /// Drop volume elements instead of refusing a volume mesh.
    pub drop_volumes: bool,
    /// Check the matching's optimality certificate too (the invariants and the validity of
    /// every quad are always checked).
    pub verify: bool,
    /// Weight of the cross-field alignment cost (eq. 7), in [0, 5]; 0.05 by default.
    pub cross_field_weight: f64,
    /// Use the harmonic cross field instead of the nearest-wall one.
    pub harmonic_cross_field: bool,
    /// Uniform refinement levels after recombination (0–3).
    pub refine: u8,
    /// Smoothing sweeps per smoothing phase; `None`: 5 · 2^refine.
    pub smooth: Option<usize>,
    /// Apply the topological operators.
    pub topology: bool,
    /// Precondition the optimizer's conformal solve on surfaces of 4,096 free nodes or more
    /// with a multigrid (on by default); off, with the diagonal, which ends further from
    /// the solve's minimizer in more time.
    pub conformal_multigrid: bool,
    /// Optimize at all (smoothing and topology).
    pub optimize: bool,
    /// Return `Ok` with the invalid quads listed in [`Report::invalid`] instead of failing.
    pub allow_invalid: bool,
    /// With second-order (6-node triangle) input: write 8-node quads (Gmsh's
    /// `Mesh.SecondOrderIncomplete`) instead of 9-node quads.
    pub incomplete: bool,
    /// Append the quality views "eta", "scaled jacobian" (`$ElementData`) and "valence"
    /// (`$NodeData`) to the result ([`crate::quality::add_views`]), encoded for
    /// [`crate::msh::default_output_format`] of the mesh (written in another encoding,
    /// they are dropped with a warning; the CLI's `--quality-view` encodes them for the
    /// format it writes).
    pub quality_view: bool,
    /// Optimize the surfaces that hold no triangle in the input (already all quads, as Gmsh's
    /// recombination, a transfinite or an extruded surface with `Recombine` leave them)
    /// like the others. By default they are written as read: their nodes (coordinates and
    /// parametric coordinates) and quads, in their order, unless parity repair or the
    /// fallback splits a curve segment they share with a triangle surface (their quads
    /// along it are then split too, to stay conforming).
    pub smooth_quads: bool,
    /// Keep the input's node and element tags exactly, gaps and all; by default the result
    /// is numbered 1..N without gaps, as Gmsh numbers its files ([`Report::renumber`]).
    pub keep_tags: bool,
    /// Give the input tag → output tag map of the kept nodes and elements in
    /// [`Report::renumber`] (`map`); ignored with [`Options::keep_tags`].
    pub tag_map: bool,
    /// Progress callback.
    #[serde(skip)]
    pub progress: Option<ProgressFn>,
    /// Developer hooks: stage times, optimizer rollbacks and matching graphs (see
    /// [`crate::Trace`]).
    #[serde(skip)]
    pub trace: Option<crate::profile::Trace>,
    /// Run the fractional start of the matching of each surface of 200,000 triangles or
    /// more in two blocks side by side (the matching's module docs): the same optimum cost
    /// with its certificate (among tied optima maybe another one, so another output), the
    /// same output on every run, a peak about 33 MB higher at 10^6 triangles. Off by
    /// default: faster only when a core is idle during the matching (figures in
    /// BENCHMARKS.md).
    pub split_matching: bool,
    /// Every input curve node stays where it is (the linear copy of a second-order mesh,
    /// whose mid-edge nodes come back on its curves): no strip end turns, whose node on a
    /// curve is not at a segment's midpoint.
    #[serde(skip)]
    pub(crate) keep_curve_nodes: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            parity: recombine::ParityMode::Repair,
            drop_volumes: false,
            verify: false,
            cross_field_weight: 0.05,
            harmonic_cross_field: false,
            refine: 0,
            smooth: None,
            topology: true,
            conformal_multigrid: true,
            optimize: true,
            allow_invalid: false,
            incomplete: false,
            quality_view: false,
            smooth_quads: false,
            keep_tags: false,
            tag_map: false,
            progress: None,
            trace: None,
            split_matching: false,
            keep_curve_nodes: false,
        }
    }
}
