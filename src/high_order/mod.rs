//! Second-order surface meshes: 6-node triangles (Gmsh type 9) with 3-node lines (type 8)
//! on curves in, 9-node quads (type 10) or, with [`ElevateOptions::incomplete`], 8-node quads
//! (type 16) with 3-node lines out. 9- and 8-node quads already in the input (Gmsh's
//! transfinite, layered and recombined faces at order 2) are kept.
//!
//! [`crate::pipeline::quadrangulate`] runs a mesh with 6-node triangles in three steps,
//! the first and the last from here (this module does not run the linear job):
//! 1. **Linear copy** ([`linearize`]): every tri6 becomes the tri3 of its corners, every
//!    quad9 or quad8 the quad4 of its corners and every line3 the line2 of its ends (same
//!    element tags; the linear job keeps existing quads); the high-order nodes no corner uses
//!    are taken out of the node blocks (and out of `$Periodic` pairs). Node tags are kept.
//! 2. **The linear job**: the whole linear pipeline on that copy (matching, parity repair,
//!    fallback, optimization, invariant and validity checks), unchanged. Its new nodes are
//!    numbered above the linear copy's largest tag; they are renumbered above the input's
//!    (one shift of every tag above the linear maximum), so no tag collides with a
//!    high-order node of the input.
//! 3. **Second order again** ([`elevate`]), on the input's curved geometry: on each
//!    surface, the map `Φ` from the flat corner triangles to the curved tri6 surface
//!    (through each triangle's quadratic shape functions; an input quad counts as two
//!    curved triangles about its diagonal 0-2, through its face node or, for an 8-node
//!    quad, its serendipity centre), and the projection onto that
//!    surface (the flat point `p` whose `Φ(p)` differs from the query only along the
//!    normal, found from the closest flat point, [`crate::quality::locate`], by a few
//!    fixed-point steps; a point of a planar surface is its own projection); on each curve,
//!    the chain of input line3 elements. Then:
//!    - an input node the linear job did not move keeps its tag and coordinates;
//!    - the mid-edge node of an input boundary edge (a line3's, or a face edge used once on
//!      its surface) that the linear job split into an even number of pieces becomes the
//!      middle corner of that chain: the new node there takes its tag and coordinates
//!      (`take_split_mid_nodes`);
//!    - a new node on a curve (parity split, fallback split, refinement) lies between the
//!      two ends of one input line3: it goes onto that line3, at the parameter its place
//!      along the chain of new segments gives (the chord-length fraction, snapped to the
//!      dyadic fraction the midpoint splits made: a single split is the parameter
//!      midpoint, i.e. the input's own mid-edge node position);
//!    - any other new or moved corner is projected onto the curved surface;
//!    - an edge of an input element whose two ends did not move keeps the input's mid-edge
//!      node (same tag, same coordinates), and an input 9-node quad whose corners did not
//!      move keeps its face node (so an input quad the linear job kept in place is written
//!      back as it was, its face node dropped for 8-node output);
//!    - any other mid-edge node is, on a curve with line3 elements, the line3 point at the
//!      mean parameter of its ends; else the projection of the midpoint of its (placed)
//!      corners onto the curved surface (a curve edge of no surface and no line3 gets its
//!      straight midpoint); a mid-edge node of a split curve segment is classified on the
//!      curve;
//!    - the face node of a 9-node quad is the projection of the centre its corners and
//!      mid-edge nodes give a serendipity quad (`Σ mid/2 − Σ corner/4`: a curved edge's
//!      bulge spreads over the element instead of folding it).
//!
//! # Validity
//! Every quad must have all the Bézier coefficients of its Jacobian determinant (a
//! polynomial of degree 3 in each reference coordinate, measured about the normal of its
//! straight-sided quad at its centre, as Gmsh measures it) strictly positive
//! ([`quad_valid`]): that implies a positive determinant over the whole element and is
//! what Gmsh's `minSJ` bound certifies; every line3 must run forward along its chord. An
//! element that fails gets straight-sided new nodes (mid-edge nodes at the midpoints of its
//! corners, the face node at the centre of that serendipity quad; the neighbour across each
//! such edge shares the straight edge); one that fails even so gets its moved corners back
//! at the linear job's positions (which the linear validity gate accepted; a straight-sided
//! quad passes exactly when its corners turn positively), and the elements around them
//! straight sides. The report's log names the elements placed straight. What still fails
//! makes the call fail ([`HighOrderError::Invalid`]) unless
//! [`ElevateOptions::allow_invalid`] is set.
//!
//! The steps live in `linearize` (step 1), `elevate` (step 3), `geometry` (the curved
//! geometry and the projection), `boundary` (mid-edge nodes handed to split chains) and
//! `jacobian` (the validity above).
//!
//! **Invariant:** the input's corner nodes the linear job kept in place, and its curve
//! nodes, keep tag and coordinates; a kept mid-edge node keeps tag and coordinates, and so
//! does the mid-edge node of a boundary edge split in two or more (as the middle new
//! corner); every new node has a tag above the input's largest; element tags, entities
//! and physical groups are the linear job's (which keeps the input's).

use std::collections::{HashMap, HashSet};
use std::hash::BuildHasherDefault;

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::mesh::NodeTable;
use crate::mesh::{element_dim, element_node_count, etype, ElementBlock, Mesh, NodeBlock};
use crate::quality::jacobian::{min_scaled_jacobian_at_nodes, quad9_derivatives, straight_normal};
use crate::quality::locate::TriSurface;
use crate::recombine::RecombineError;

mod boundary;
mod elevate;
mod geometry;
mod jacobian;
mod linearize;

pub use elevate::elevate;
pub use geometry::line3_point;
#[cfg(any(test, feature = "testing"))]
pub use geometry::tri6_point;
#[cfg(any(test, feature = "testing"))]
pub use jacobian::jacobian_positive;
pub use jacobian::quad_valid;
pub use linearize::linearize;

use boundary::{chain_between, chain_parameters, take_split_mid_nodes};
use geometry::{serendipity_centre, Geometry};
use jacobian::line_valid;

/// Hasher of the maps below, whose keys are node tags, tag pairs and entity tags: a
/// multiply-rotate step per word (as rustc's FxHash) and a SplitMix64 finish (so that
/// tags in arithmetic progressions still spread over the buckets). Several times faster
/// than the default SipHash on these small keys.
#[derive(Default, Clone, Copy)]
struct TagHasher(u64);

impl std::hash::Hasher for TagHasher {
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(word));
        }
    }
    fn write_u64(&mut self, x: u64) {
        self.0 = (self.0.rotate_left(5) ^ x).wrapping_mul(0x517c_c1b7_2722_0a95);
    }
    fn write_u32(&mut self, x: u32) {
        self.write_u64(u64::from(x));
    }
    fn write_i32(&mut self, x: i32) {
        self.write_u64(u64::from(x as u32));
    }
    fn write_usize(&mut self, x: usize) {
        self.write_u64(x as u64);
    }
    fn finish(&self) -> u64 {
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
}

type FastMap<K, V> = HashMap<K, V, BuildHasherDefault<TagHasher>>;
type FastSet<K> = HashSet<K, BuildHasherDefault<TagHasher>>;

/// Why the second-order path refused a mesh or could not make it valid.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum HighOrderError {
    /// The linear copy was refused as the linear job refuses a mesh (an unknown node, a
    /// malformed block, volume elements).
    #[error(transparent)]
    Recombine(#[from] RecombineError),
    /// An element type the second-order path does not handle.
    #[error("entity ({dim}, {entity}) has {count} elements of type {element_type}; a second-order mesh must have 6-node triangles (type 9, and 3-node triangles), 9- or 8-node quads (types 10, 16) on surfaces and 3-node lines (type 8, and 2-node lines) on curves: mesh with Mesh.ElementOrder = 2 or 1")]
    Unsupported {
        /// Entity dimension.
        dim: i32,
        /// Entity tag.
        entity: i32,
        /// Gmsh element type code.
        element_type: u32,
        /// How many.
        count: usize,
    },
    /// Second-order quads whose Jacobian is not positive even with straight-sided nodes.
    #[error("{count} second-order element(s) have a Jacobian determinant that is not positive everywhere even with straight-sided nodes; first: element {element} on entity ({dim}, {entity})")]
    Invalid {
        /// Entity dimension of the first bad element.
        dim: i32,
        /// Entity tag of the first bad element.
        entity: i32,
        /// Its element tag.
        element: u64,
        /// How many elements are bad.
        count: usize,
    },
}

/// What the second-order step did.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct SecondOrderReport {
    /// Gmsh type of the quads written (10 = 9-node, 16 = 8-node).
    pub quad_type: u32,
    /// Quads written.
    pub quads: usize,
    /// 3-node lines written.
    pub lines: usize,
    /// Input mid-edge nodes kept (tag and coordinates).
    pub kept_mid_nodes: usize,
    /// New mid-edge nodes on curves (on the input's line3 chains).
    pub curve_mid_nodes: usize,
    /// New mid-edge nodes on surfaces (on the input's curved surface).
    pub surface_mid_nodes: usize,
    /// New face nodes (9-node quads).
    pub face_nodes: usize,
    /// Face nodes of input 9-node quads kept (tag and coordinates).
    pub kept_face_nodes: usize,
    /// New or moved corner nodes placed on the curved geometry.
    pub corners_placed: usize,
    /// Tags of the elements given straight-sided new nodes to stay valid.
    pub straight: Vec<u64>,
    /// Corner nodes put back at the linear position to keep an element valid.
    pub corners_reverted: usize,
    /// Elements still not valid (only with `allow_invalid`).
    pub invalid: Vec<u64>,
    /// Smallest scaled Jacobian at the nodes over all quads.
    pub min_scaled_jacobian: f64,
    /// Mean over quads of their smallest scaled Jacobian at the nodes.
    pub mean_scaled_jacobian: f64,
}

/// True when `mesh` has 6-node triangles, or 9- or 8-node quads, on some surface (the
/// second-order path).
pub fn is_second_order(mesh: &Mesh) -> bool {
    mesh.element_blocks.iter().any(|b| {
        b.entity_dim == 2
            && matches!(b.element_type, etype::TRI6 | etype::QUAD9 | etype::QUAD8)
            && !b.is_empty()
    })
}

/// How [`elevate`] builds and checks the second-order elements.
#[derive(Debug, Clone, Copy, Default)]
pub struct ElevateOptions {
    /// 8-node quads (type 16) instead of 9-node ones.
    pub incomplete: bool,
    /// Write elements whose Jacobian is not positive everywhere (listed in
    /// [`SecondOrderReport::invalid`]) instead of refusing them.
    pub allow_invalid: bool,
}

/// Sorted pair of node tags: the key of an edge.
pub(super) fn key(a: u64, b: u64) -> (u64, u64) {
    if a < b {
        (a, b)
    } else {
        (b, a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::Options;

    fn square9(bulge: f64) -> [DVec3; 9] {
        let p = |x: f64, y: f64| DVec3::new(x, y, 0.0);
        [
            p(0.0, 0.0),
            p(1.0, 0.0),
            p(1.0, 1.0),
            p(0.0, 1.0),
            p(0.5, bulge),
            p(1.0, 0.5),
            p(0.5, 1.0),
            p(0.0, 0.5),
            p(0.5, 0.5 + bulge * 0.5),
        ]
    }

    #[test]
    fn straight_square_is_valid_and_scaled_jacobian_one() {
        let x = square9(0.0);
        assert!(quad_valid(&x, DVec3::Z));
        assert!((min_scaled_jacobian_at_nodes(&x) - 1.0).abs() < 1e-12);
        assert!(
            !quad_valid(&x, -DVec3::Z),
            "orientation against the reference"
        );
    }

    #[test]
    fn a_bulge_past_the_opposite_side_folds_the_quad() {
        assert!(quad_valid(&square9(0.2), DVec3::Z));
        // the bottom edge's mid node pushed above the top edge
        let x = square9(1.3);
        assert!(!quad_valid(&x, DVec3::Z));
    }

    #[test]
    fn whole_element_check_agrees_with_dense_sampling_on_random_quads() {
        // perturbed unit squares: the check must never accept a quad whose Jacobian is
        // not positive at some sample, and must accept those clearly positive everywhere
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let (mut accepted, mut refused) = (0, 0);
        for _ in 0..400 {
            let mut x = square9(0.0);
            // corners moved less than a quarter of the side keep the quad convex
            for p in x.iter_mut().take(4) {
                *p += DVec3::new(rnd(), rnd(), 0.0) * 0.45;
            }
            for p in x.iter_mut().skip(4) {
                *p += DVec3::new(rnd(), rnd(), 0.0) * 0.3;
            }
            let n = straight_normal(&x).normalize();
            let mut min = f64::INFINITY;
            for i in 0..=40 {
                for j in 0..=40 {
                    let (u, v) = (-1.0 + i as f64 / 20.0, -1.0 + j as f64 / 20.0);
                    let (xu, xv) = quad9_derivatives(&x, u, v);
                    min = min.min(xu.cross(xv).dot(n));
                }
            }
            let ok = quad_valid(&x, DVec3::Z);
            if min <= 0.0 {
                assert!(!ok, "accepted a quad with det J {min} at a sample");
            }
            // straight sides: accepted exactly when the corners turn positively
            let mut straight = x;
            for k in 0..4 {
                straight[4 + k] = (x[k] + x[(k + 1) % 4]) * 0.5;
            }
            straight[8] = serendipity_centre(&straight);
            assert!(
                quad_valid(&straight, DVec3::Z),
                "straight convex quad refused"
            );
            if ok {
                accepted += 1;
            } else {
                refused += 1;
            }
        }
        assert!(
            accepted > 20 && refused > 20,
            "{accepted} accepted, {refused} refused"
        );
    }

    #[test]
    fn bezier_bounds_agree_with_dense_sampling() {
        // f = (u - a)^2 + (v - b)^2 + c, positive iff c > 0 (for a point inside the box)
        for &(a, b, c, positive) in &[
            (0.3, -0.2, 0.01, true),
            (0.3, -0.2, -0.01, false),
            (2.0, 2.0, -1.0, true),
            (0.0, 0.0, 1e-6, true),
        ] {
            let f = |u: f64, v: f64| (u - a) * (u - a) + (v - b) * (v - b) + c;
            assert_eq!(jacobian_positive(&f, 6), positive, "a {a} b {b} c {c}");
        }
        // the whole element's coefficients alone do not certify a minimum inside it
        let f = |u: f64, v: f64| u * u + v * v + 1e-6;
        assert!(jacobian_positive(&f, 6) && !jacobian_positive(&f, 0));
    }

    #[test]
    fn tri6_and_line3_interpolate_their_nodes() {
        let x = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.1),
            DVec3::new(0.0, 1.0, 0.2),
            DVec3::new(0.5, 0.0, 0.3),
            DVec3::new(0.5, 0.5, 0.4),
            DVec3::new(0.0, 0.5, 0.5),
        ];
        assert_eq!(tri6_point(&x, [1.0, 0.0, 0.0]), x[0]);
        assert_eq!(tri6_point(&x, [0.5, 0.5, 0.0]), x[3]);
        assert_eq!(tri6_point(&x, [0.0, 0.5, 0.5]), x[4]);
        assert_eq!(tri6_point(&x, [0.5, 0.0, 0.5]), x[5]);
        let (a, b, m) = (x[0], x[1], x[3]);
        assert_eq!(line3_point(a, b, m, -1.0), a);
        assert_eq!(line3_point(a, b, m, 0.0), m);
        assert_eq!(line3_point(a, b, m, 1.0), b);
        assert!(line_valid(a, b, m));
        assert!(!line_valid(a, b, DVec3::new(1.2, 0.0, 0.0)));
    }

    #[test]
    fn chain_parameters_recover_midpoint_splits() {
        let p = |x: f64| DVec3::new(x, 0.0, 0.0);
        let xi = chain_parameters(&[p(0.0), p(0.52), p(1.0)]);
        assert_eq!(xi, vec![-1.0, 0.0, 1.0]);
        let xi = chain_parameters(&[p(0.0), p(0.24), p(0.51), p(1.0)]);
        assert_eq!(xi, vec![-1.0, -0.5, 0.0, 1.0]);
        let xi = chain_parameters(&[p(0.0), p(0.26), p(0.49), p(0.76), p(1.0)]);
        assert_eq!(xi, vec![-1.0, -0.5, 0.0, 0.5, 1.0]);
    }

    /// Two 6-node triangles making the unit square (mid-edge nodes have the largest tags,
    /// as Gmsh numbers them; the bottom edge's mid node bulges out of the plane).
    fn two_tri6() -> Mesh {
        use crate::mesh::{Entity, NodeBlock};
        let mut m = Mesh::default();
        m.entities[2].push(Entity {
            dim: 2,
            tag: 1,
            bbox: [0.0, 0.0, 0.0, 1.0, 1.0, 0.0],
            physical_tags: vec![],
            bounding: vec![],
        });
        let coords = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.5, 0.0, 0.05], // 5: mid 1-2
            [1.0, 0.5, 0.0],  // 6: mid 2-3
            [0.5, 0.5, 0.0],  // 7: mid 3-1 (the diagonal)
            [0.5, 1.0, 0.0],  // 8: mid 3-4
            [0.0, 0.5, 0.0],  // 9: mid 4-1
        ];
        m.node_blocks.push(NodeBlock {
            entity_dim: 2,
            entity_tag: 1,
            tags: (1..=9).collect(),
            coords,
            params: None,
        });
        m.element_blocks.push(ElementBlock {
            entity_dim: 2,
            entity_tag: 1,
            element_type: etype::TRI6,
            tags: vec![1, 2],
            nodes: vec![1, 2, 3, 5, 6, 7, 1, 3, 4, 7, 8, 9],
            partitions: None,
        });
        m
    }

    #[test]
    fn linearize_checks_blocks_as_the_linear_job_does() {
        let malformed = |e: &HighOrderError| {
            matches!(
                e,
                HighOrderError::Recombine(RecombineError::MalformedBlock { .. })
            )
        };
        // a type of unknown size: kept when empty, unsupported (not malformed) otherwise
        let mut m = two_tri6();
        let unknown = ElementBlock {
            entity_dim: 2,
            entity_tag: 1,
            element_type: 1000,
            tags: vec![],
            nodes: vec![],
            partitions: None,
        };
        m.element_blocks.push(unknown.clone());
        let (lin, _) = linearize(&m, false).expect("an empty block of any type is kept");
        assert!(lin.element_blocks.iter().any(|b| b.element_type == 1000));
        m.element_blocks.pop();
        m.element_blocks.push(ElementBlock {
            tags: vec![7],
            nodes: vec![1, 2, 3],
            ..unknown
        });
        let e = linearize(&m, false).expect_err("unknown type refused");
        assert!(matches!(e, HighOrderError::Unsupported { .. }), "{e}");
        // one partition list per element, as recombination requires
        let mut m = two_tri6();
        m.element_blocks[0].partitions = Some(vec![vec![1]]);
        let e = linearize(&m, false).expect_err("partitions of one element for two");
        assert!(malformed(&e), "{e}");
        let mut m = two_tri6();
        m.element_blocks[0].nodes.pop();
        let e = linearize(&m, false).expect_err("a node short");
        assert!(malformed(&e), "{e}");
    }

    #[test]
    fn two_triangles_become_one_quad9_keeping_the_boundary_mid_nodes() {
        // numbered 1..N, the mid-edge nodes 8 and 9 would become 7 and 8 (7 is gone): the
        // tags are compared with the input's
        let mut renumbered = two_tri6();
        let plain = Options {
            optimize: false,
            ..Default::default()
        };
        crate::pipeline::quadrangulate(&mut renumbered, &plain).expect("recombined");
        let mut m = two_tri6();
        let mut opts = Options {
            optimize: false,
            keep_tags: true,
            ..Default::default()
        };
        let report = crate::pipeline::quadrangulate(&mut m, &opts).expect("recombined");
        let so = report.second_order.expect("second-order report");
        assert_eq!((so.quads, so.kept_mid_nodes, so.face_nodes), (1, 4, 1));
        let b = m
            .element_blocks
            .iter()
            .find(|b| b.entity_dim == 2)
            .expect("a surface block");
        assert_eq!(b.element_type, etype::QUAD9);
        assert_eq!(b.len(), 1);
        let e = b.element(0);
        // the four edges keep their input mid-edge nodes, the diagonal's (7) is gone, the
        // face node is new, above the input's largest tag
        let mut mids: Vec<u64> = e[4..8].to_vec();
        mids.sort_unstable();
        assert_eq!(mids, vec![5, 6, 8, 9]);
        assert!(e[8] > 9);
        let tags: Vec<u64> = m.node_blocks.iter().flat_map(|b| b.tags.clone()).collect();
        assert!(!tags.contains(&7) && tags.contains(&e[8]));
        let face = renumbered
            .element_blocks
            .iter()
            .find(|b| b.entity_dim == 2)
            .expect("a surface block")
            .element(0)
            .to_vec();
        let mut renumbered_mids: Vec<u64> = face[4..8].to_vec();
        renumbered_mids.sort_unstable();
        assert_eq!((renumbered_mids, face[8]), (vec![5, 6, 7, 8], 9));
        // the face node: the serendipity centre (0.5, 0.5, 0.025: half the bottom edge's
        // bulge) projected back onto the input surface, which is flat along the diagonal
        let index = m.node_index();
        let r = index.get(e[8]).expect("face node exists");
        let c = DVec3::from_array(m.node_blocks[r.block as usize].coords[r.index as usize]);
        assert!(c.distance(DVec3::new(0.5, 0.5, 0.0)) < 1e-12, "{c:?}");
        // --incomplete: an 8-node quad, no face node
        let mut m = two_tri6();
        opts.incomplete = true;
        crate::pipeline::quadrangulate(&mut m, &opts).expect("recombined");
        let b = m
            .element_blocks
            .iter()
            .find(|b| b.entity_dim == 2)
            .expect("block");
        assert_eq!((b.element_type, b.nodes.len()), (etype::QUAD8, 8));
    }

    #[test]
    fn quality_view_option_measures_the_second_order_result() {
        let mut m = two_tri6();
        let opts = Options {
            optimize: false,
            quality_view: true,
            ..Default::default()
        };
        crate::pipeline::quadrangulate(&mut m, &opts).expect("recombined");
        // eta, scaled jacobian, valence: once each (not also from the linear copy),
        // ASCII (the mesh has no format: MSH 4.1 ASCII by default)
        assert_eq!(m.data_sections.len(), 3);
        assert!(m
            .data_sections
            .iter()
            .all(|d| d.encoded_binary == Some(false)));
        let text = String::from_utf8_lossy(&m.data_sections[1].body).into_owned();
        assert!(text.starts_with("1\n\"scaled jacobian\""), "{text}");
        // one quad: one row, its tag and its value at the nodes
        let q = m
            .element_blocks
            .iter()
            .find(|b| b.element_type == etype::QUAD9)
            .expect("a quad9 block");
        let rows: Vec<&str> = text.lines().skip(8).collect();
        assert_eq!(rows.len(), 1, "{text}");
        let (tag, value) = rows[0].split_once(' ').expect("tag value");
        assert_eq!(tag.parse::<u64>().ok(), Some(q.tags[0]));
        let v: f64 = value.parse().expect("a number");
        assert!(v > 0.5 && v <= 1.0, "{v}");
    }

    #[test]
    fn third_order_triangles_are_refused_and_the_mesh_is_unchanged() {
        let mut m = two_tri6();
        m.element_blocks.push(ElementBlock {
            entity_dim: 2,
            entity_tag: 1,
            element_type: 21,
            tags: vec![3],
            nodes: vec![1, 2, 3, 5, 5, 6, 6, 7, 7, 8],
            partitions: None,
        });
        let before = m.clone();
        let e = crate::pipeline::quadrangulate(&mut m, &Options::default()).unwrap_err();
        assert!(e.to_string().contains("type 21"), "{e}");
        assert_eq!(m, before);
    }
}
