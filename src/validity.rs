//! The validity gate: what every quad written by [`crate::quadrangulate`] satisfies.
//!
//! A quad is **valid** when
//! - its four nodes exist and are distinct;
//! - no edge has zero length (below [`MIN_EDGE`] times the mesh's extent);
//! - each corner angle is strictly between 0° and 180° (corner quality of eq. 3 above
//!   [`MIN_CORNER_ETA`]), measured in 3D about the *input* surface's normal at that corner:
//!   the area-weighted normal of the input faces of the same surface around the corner's
//!   node, oriented like them. So a quad that turned over (inverted, or oriented against
//!   the triangles it came from) fails at its corners, and so does a flat (180°) or reflex
//!   corner. A corner at a node the input surface does not have (vertex duplications,
//!   parity and fallback splits, refinement), or whose input faces cancel out, takes the
//!   summed normal of the input faces of the surface nearest to a point inside the corner,
//!   a quarter of the way along its two edges (every face within 1e-9 of the input's
//!   extent of the nearest distance counts): the faces the quad lies on there, where the node
//!   itself, at the midpoint of an input edge, is as near to the faces on both sides of
//!   that edge, which on a coarse curved surface turn far apart; the quad's own normal only
//!   when the surface has no face at all. Where those nearest faces cancel out too (a
//!   surface folded back onto itself), the corner has no normal and the quad is not valid.
//!   Where the surface
//!   wraps round a node (one of its faces there turns 90° or more from the node's normal,
//!   [`WRAP_COS`]: a fold, a pin a few triangles round), that normal stands for no side of
//!   the surface, and a corner there is measured on its own side: about the mean unit
//!   normal of the input faces at that node the quad holds (all their nodes among the
//!   quad's), else, where it holds none (a node the run added is one of its corners),
//!   about the input faces nearest to the point inside the corner. Where the surface folds
//!   over itself, several faces lie at that point, and only those the quad holds say which
//!   side it is on;
//! - no corner is seen edge-on from the surface (its sine about that normal above
//!   [`MIN_SINE`] of its edges' lengths);
//! - on a curved surface, each corner also turns positively about the mean unit normal of
//!   the input faces the quad came from (those whose nodes are all among the quad's, else
//!   those sharing two nodes with it, else one), where one normal stands for the quad: no
//!   node of it wrapped, and no input face at its nodes turning 60° or more from that mean
//!   (`TURN_COS`). A quad holding an input triangle and a new node far off the
//!   triangle's plane can have a corner edge-on to that triangle and positive about every
//!   node's normal (`tests/check_mesh.py` measures it so, and found one on a coarse
//!   boolean part);
//! - where no one normal stands for it so, the quad faces the input's way: its own normal
//!   turns less than 90° from the sum of the normals its corners are measured about
//!   ([`Defect::TurnedOver`]; `tests/check_mesh.py` asks the same);
//! - the quad holds to its own geometry: its scaled Jacobian at each corner about its *own*
//!   normal (the cross product of its diagonals, the normal of the bilinear map at the
//!   quad's centre) is above `tan ε`, ε the angle of [`MIN_CORNER_ETA`]. The Jacobian
//!   determinant of a 4-node quad about that normal is linear over the reference square,
//!   so positive corners mean it is positive everywhere: what a solver integrates on and
//!   the sign of Gmsh's `minSJ` (Gmsh's `minSICN`, a bound of another measure, can be
//!   negative on a quad bent across a coarse curved face whose `minSJ` is positive). A
//!   quad strongly bent across a
//!   coarse curved face (a fillet of a few triangles) can turn positively about every
//!   input normal and still fold about its own.
//!
//! A quad bent across a sharp turn of a coarse curved surface (a pair of triangles turning
//! far apart) can be valid with a corner that turns positively about its own node's normal
//! and is reflex about the normal at another node of the quad. The pipeline's rounds ask
//! that too ([`Bent::Refused`]: every corner turns positively, sine above [`MIN_SINE`],
//! about the input normal at every node of the quad the input has and does not wrap
//! round), and accept bent quads only in the job it runs where the others cascaded.
//!
//! [`invalid_quads`] lists every quad that is not valid; it shares no code with the
//! recombination or the optimizer, which it checks, except the closest-point grid of
//! `quality::locate` for the nearest faces (the fuzz target checks that by brute force).

use glam::DVec3;
use rayon::prelude::*;

use crate::keysort::radix_sort_by_key;
use crate::mesh::{etype, Mesh, TagCoords};

/// Smallest corner quality (eq. 3, one corner) counted as strictly inside (0°, 180°):
/// angles within about 1e-4 degree of 0° or 180° are flat.
pub const MIN_CORNER_ETA: f64 = 1e-6;

/// tan ε with ε the angle whose corner quality is [`MIN_CORNER_ETA`].
static MIN_TAN: std::sync::LazyLock<f64> =
    std::sync::LazyLock::new(|| (MIN_CORNER_ETA * std::f64::consts::FRAC_PI_2).tan());

/// Smallest sine of a corner about the reference normal (relative to its two edges'
/// lengths): a corner whose plane is about perpendicular to the surface is not valid even
/// when its in-plane angle is right.
pub const MIN_SINE: f64 = 1e-9;

/// A face whose unit normal has at most this dot product with its node's normal (it turns
/// 90° or more from it) makes the node wrapped: the surface turns round it too sharply for
/// one normal to stand for the side of the surface a corner there is on (a fold, a pin a few
/// triangles round).
pub const WRAP_COS: f64 = 0.0;

/// Shortest edge counted as non-zero, relative to the diagonal of the mesh's bounding box.
pub const MIN_EDGE: f64 = 1e-12;

/// Why a quad is not valid.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[non_exhaustive]
pub enum Defect {
    /// A node tag that no node block holds.
    MissingNode(u64),
    /// The same node twice.
    RepeatedNode(u64),
    /// The edge from corner `corner` to the next has (near) zero length.
    ZeroLengthEdge {
        /// Index 0–3 of the edge's first corner.
        corner: usize,
    },
    /// Corner `corner`'s angle, in degrees, is not strictly between 0 and 180 (about the
    /// input surface's normal: negative or above 180 means turned over or reflex).
    Corner {
        /// Index 0–3 of the corner.
        corner: usize,
        /// The signed angle in degrees, in (−180, 180].
        degrees: f64,
    },
    /// Corner `corner`'s scaled Jacobian about the quad's own normal (the cross product of
    /// its diagonals) is not positive: the element folds over itself there.
    OwnJacobian {
        /// Index 0–3 of the corner.
        corner: usize,
        /// The scaled Jacobian at that corner, in [−1, 1].
        scaled: f64,
    },
    /// Corner `corner` is at a node where both the input's faces and the input faces
    /// nearest to it cancel out (the surface folds back onto itself there): it has no
    /// normal to be measured about.
    NoNormal {
        /// Index 0–3 of the corner.
        corner: usize,
    },
    /// The quad faces away from the input surface: its own normal (the cross product of its
    /// diagonals) turns 90° or more from the sum of the normals its corners are measured
    /// about, where no one normal of the input faces it came from stands for it.
    TurnedOver,
}

/// One quad that is not valid.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct BadQuad {
    /// Surface entity tag.
    pub surface: i32,
    /// Element tag.
    pub element: u64,
    /// The quad's node tags.
    pub nodes: [u64; 4],
    /// What is wrong (the first defect found).
    pub defect: Defect,
}

impl Defect {
    /// The same defect at corner `corner` (a defect at no corner as it is).
    pub(crate) fn at_corner(self, corner: usize) -> Defect {
        match self {
            Defect::ZeroLengthEdge { .. } => Defect::ZeroLengthEdge { corner },
            Defect::Corner { degrees, .. } => Defect::Corner { corner, degrees },
            Defect::OwnJacobian { scaled, .. } => Defect::OwnJacobian { corner, scaled },
            Defect::NoNormal { .. } => Defect::NoNormal { corner },
            other => other,
        }
    }
}

impl BadQuad {
    /// The node tag the defect is at (the bad corner, the first node of a zero edge, the
    /// missing or repeated node, or the first node of a quad turned over as a whole).
    pub fn node(&self) -> u64 {
        match self.defect {
            Defect::MissingNode(t) | Defect::RepeatedNode(t) => t,
            Defect::ZeroLengthEdge { corner }
            | Defect::Corner { corner, .. }
            | Defect::OwnJacobian { corner, .. }
            | Defect::NoNormal { corner } => self.nodes[corner],
            Defect::TurnedOver => self.nodes[0],
        }
    }
}

impl std::fmt::Display for BadQuad {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let [a, b, c, d] = self.nodes;
        write!(
            f,
            "surface {}, quad {} (nodes {a} {b} {c} {d}): ",
            self.surface, self.element
        )?;
        match &self.defect {
            Defect::MissingNode(t) => write!(f, "node {t} does not exist"),
            Defect::RepeatedNode(t) => write!(f, "node {t} is used twice"),
            Defect::ZeroLengthEdge { corner } => write!(
                f,
                "edge {}-{} has zero length",
                self.nodes[*corner],
                self.nodes[(corner + 1) % 4]
            ),
            Defect::Corner { corner, degrees } => write!(
                f,
                "the corner at node {} is not strictly between 0 and 180 degrees \
                 ({degrees:.2} degrees about the input surface's normal: flat, reflex or \
                 turned over)",
                self.nodes[*corner]
            ),
            Defect::OwnJacobian { corner, scaled } => write!(
                f,
                "the quad folds over itself at node {} (scaled Jacobian {scaled:.3} about its \
                 own normal, the cross product of its diagonals)",
                self.nodes[*corner]
            ),
            Defect::NoNormal { corner } => write!(
                f,
                "the corner at node {} has no input normal to be measured about (the input \
                 faces nearest to it face opposite ways: the surface folds back onto itself \
                 there)",
                self.nodes[*corner]
            ),
            Defect::TurnedOver => write!(
                f,
                "the quad faces away from the input surface (its own normal turns 90 degrees \
                 or more from the input normals its corners are measured about)"
            ),
        }
    }
}

/// Every 4-node quad of `output` that is not valid (see the module doc), by surface tag
/// then block order. `input` is the mesh the quads came from: its faces (triangles and
/// quads) give the reference normals.
#[cfg(any(test, feature = "testing"))]
pub fn invalid_quads(input: &Mesh, output: &Mesh) -> Vec<BadQuad> {
    Reference::new(input).invalid_quads(output)
}

/// The input side of [`invalid_quads`], prepared once for any number of outputs of the
/// same input: the input's node index and, per surface, the normals at its nodes (the
/// nearest-face search of a surface is built on the first quad node that needs it).
pub struct Reference<'a> {
    input: &'a Mesh,
    /// The input's coordinates by tag (memory: shared with the invariants' baseline when
    /// the pipeline prepares both).
    coords: std::sync::Arc<TagCoords<'a>>,
    /// Input surfaces with faces, by increasing tag.
    surfaces: Vec<(i32, SurfaceReference)>,
    /// Faces this much farther from a point than the nearest one still count as nearest
    /// (1e-9 of the input's extent): a property of the input alone, so a surface's
    /// nearest-face search, built once, serves every output checked against it.
    tie: f64,
}

/// One input surface's normals and, once needed, its nearest-face search.
struct SurfaceReference {
    normals: Normals,
    nearest: std::sync::OnceLock<Nearest>,
    /// The faces by node, for curved surfaces (built with the rest, or on the first quad of
    /// a surface the input has no face of).
    source: std::sync::OnceLock<SourceFaces>,
}

impl<'a> Reference<'a> {
    /// Prepares the check against `input`.
    #[cfg(any(test, feature = "testing"))]
    pub fn new(input: &'a Mesh) -> Self {
        Self::with_coords(input, std::sync::Arc::new(TagCoords::new(input)))
    }

    /// [`Reference::new`] with `coords`, the coordinates of `input`'s nodes by tag.
    pub(crate) fn with_coords(input: &'a Mesh, coords: std::sync::Arc<TagCoords<'a>>) -> Self {
        let surfaces = input
            .sorted_surfaces(|b| b.is_linear_face())
            .par_iter()
            .map(|&s| (s, SurfaceReference::new(input, &coords, s)))
            .collect();
        Reference {
            input,
            coords,
            surfaces,
            tie: extent(input) * 1e-9,
        }
    }

    /// [`invalid_quads`] of `output` against this input.
    #[cfg(any(test, feature = "testing"))]
    pub fn invalid_quads(&self, output: &Mesh) -> Vec<BadQuad> {
        self.invalid_quads_on(output, &TagCoords::new(output), |_| true, Bent::Accepted)
    }

    /// [`Reference::invalid_quads`] on every surface of `output` but those of `except`
    /// (sorted tags): surfaces known to pass, with the same quads at the same coordinates
    /// and the same [`check_key`], in an output checked before; `bent` as in the key.
    pub(crate) fn invalid_quads_except(
        &self,
        output: &Mesh,
        out_coords: &TagCoords,
        except: &[i32],
        bent: Bent,
    ) -> Vec<BadQuad> {
        self.invalid_quads_on(output, out_coords, |s| except.binary_search(&s).is_err(), bent)
    }

    /// A node the input surface `surface` wraps round (one of its faces there turns 90° or
    /// more from the node's normal, [`WRAP_COS`]): one of `prefer` when the surface wraps
    /// round one of them, else its wrapped node of the smallest tag; `None` when it wraps
    /// round none.
    pub(crate) fn wrapped_node(&self, surface: i32, prefer: &[u64]) -> Option<u64> {
        self.wrapped_among(surface, prefer)
            .or_else(|| self.normals(surface)?.wrapped.first().copied())
    }

    /// The first of `nodes` (the smallest tag when sorted) that input surface `surface`
    /// wraps round ([`Reference::wrapped_node`]), if any.
    pub(crate) fn wrapped_among(&self, surface: i32, nodes: &[u64]) -> Option<u64> {
        let normals = self.normals(surface)?;
        nodes.iter().copied().find(|&t| normals.wraps(t))
    }

    /// The input normals of surface `surface`, when the input has faces of it.
    fn normals(&self, surface: i32) -> Option<&Normals> {
        let i = self.surfaces.binary_search_by_key(&surface, |x| x.0).ok()?;
        Some(&self.surfaces[i].1.normals)
    }

    /// [`Reference::invalid_quads`] on the surfaces `on` accepts, with `out_coords`, the
    /// coordinates of `output`'s nodes by tag, and quads bent across a sharp turn of a
    /// curved surface accepted or refused ([`Bent`]).
    pub(crate) fn invalid_quads_on(
        &self,
        output: &Mesh,
        out_coords: &TagCoords,
        on: impl Fn(i32) -> bool,
        bent: Bent,
    ) -> Vec<BadQuad> {
        let extent = extent(output);
        let min_edge = MIN_EDGE * extent;
        let mut surfaces = output.sorted_surfaces(|b| b.element_type == etype::QUAD4 && !b.is_empty());
        surfaces.retain(|&s| on(s));
        surfaces
            .par_iter()
            .flat_map_iter(|&s| {
                // a surface the input has no face of: no normal, no nearest face
                let absent;
                let sr = match self.surfaces.binary_search_by_key(&s, |x| x.0) {
                    Ok(i) => &self.surfaces[i].1,
                    Err(_) => {
                        absent = SurfaceReference::new(self.input, &self.coords, s);
                        &absent
                    }
                };
                let nearest = || {
                    sr.nearest.get_or_init(|| {
                        Nearest::new(input_faces(self.input, &self.coords, s), self.tie)
                    })
                };
                let source = || {
                    sr.source
                        .get_or_init(|| SourceFaces::new(self.input, &self.coords, s))
                };
                let mut bad = Vec::new();
                for b in output.element_blocks.iter().filter(|b| {
                    b.entity_dim == 2 && b.entity_tag == s && b.element_type == etype::QUAD4
                }) {
                    // speed: quads in parallel within a surface too (one large surface)
                    let found: Vec<BadQuad> = (0..b.len())
                        .into_par_iter()
                        .with_min_len(4096)
                        .filter_map(|i| {
                            let e = b.element(i);
                            let nodes = [e[0], e[1], e[2], e[3]];
                            check_quad(out_coords, &sr.normals, &nearest, &source, nodes, min_edge, bent)
                                .map(
                                |defect| BadQuad {
                                    surface: s,
                                    element: b.tags[i],
                                    nodes,
                                    defect,
                                },
                            )
                        })
                        .collect();
                    bad.extend(found);
                }
                bad
            })
            .collect()
    }
}

impl SurfaceReference {
    fn new(input: &Mesh, coords: &TagCoords, s: i32) -> Self {
        let normals = input_normals(input, coords, s);
        // speed: every quad of a curved surface needs its faces by node, built here (the
        // pipeline prepares this while the optimizer runs)
        let source = if normals.planar {
            std::sync::OnceLock::new()
        } else {
            std::sync::OnceLock::from(SourceFaces::new(input, coords, s))
        };
        SurfaceReference {
            normals,
            nearest: std::sync::OnceLock::new(),
            source,
        }
    }
}

/// What the check of one surface's quads reads of the rest of `output`, and how it judges
/// bent quads: the same quads over the same input nodes at the same coordinates (nodes the
/// input lacks under any tag) give the same result in two outputs with the same key (the
/// length under which an edge is too short scales with the output's extent).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) struct CheckKey {
    extent: u64,
    bent: Bent,
}

/// The [`CheckKey`] of `output` checked with bent quads accepted or refused.
pub(crate) fn check_key(output: &Mesh, bent: Bent) -> CheckKey {
    CheckKey {
        extent: extent(output).to_bits(),
        bent,
    }
}

/// The diagonal of the bounding box of all nodes (1 for an empty mesh).
fn extent(mesh: &Mesh) -> f64 {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for b in &mesh.node_blocks {
        for c in &b.coords {
            let p = DVec3::from_array(*c);
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    let d = (hi - lo).length();
    if d.is_finite() && d > 0.0 {
        d
    } else {
        1.0
    }
}

/// The unit input normals of one surface by node tag (zero where the faces around a node
/// cancel): a table indexed by tag when the surface's nodes are a good share of the tag
/// range, else sorted pairs.
struct Normals {
    at: NodeNormals,
    /// The wrapped nodes (see [`Normals::wraps`]), sorted.
    wrapped: Vec<u64>,
    /// Every face of the surface has the same unit normal (to rounding): the normals at
    /// the nodes and those of the faces a quad came from are all that one.
    planar: bool,
}

/// The unit normals by node tag: a table indexed by tag, or sorted pairs.
enum NodeNormals {
    Dense(Vec<DVec3>),
    Sorted(Vec<(u64, DVec3)>),
}

impl NodeNormals {
    /// The unit normal at node `t` (zero where the faces around it cancel), when the
    /// surface has the node.
    fn get(&self, t: u64) -> Option<DVec3> {
        match self {
            NodeNormals::Dense(d) => d.get(t as usize).copied(),
            NodeNormals::Sorted(p) => p.binary_search_by_key(&t, |x| x.0).ok().map(|i| p[i].1),
        }
    }
}

impl Normals {
    /// The unit normal at node `t`, when the input has one there (not zero).
    fn get(&self, t: u64) -> Option<DVec3> {
        self.at.get(t).filter(|n| *n != DVec3::ZERO)
    }

    /// Whether the surface wraps round node `t`: one of its faces there turns 90° or more
    /// ([`WRAP_COS`]) from the node's normal (a fold, or a pin meshed coarser than its
    /// radius, a few triangles round). The node's normal then stands for no side of the
    /// surface, and a corner there is measured about its own side ([`own_side`]).
    fn wraps(&self, t: u64) -> bool {
        !self.wrapped.is_empty() && self.wrapped.binary_search(&t).is_ok()
    }
}

/// The point a corner at `p` with edges `a` and `b` (to its two neighbours) is measured
/// at when its node is one the input lacks, or is wrapped ([`Normals::wraps`]) and the quad
/// holds no input face there: a quarter of the way along both edges, inside the corner,
/// where the faces the quad lies on are nearest.
fn own_side(p: DVec3, a: DVec3, b: DVec3) -> DVec3 {
    p + 0.25 * (a + b)
}

/// Faces per parallel task.
const CHUNK: usize = 8192;

/// Faces whose normals are computed (in parallel) before they are added at their nodes.
const BATCH: usize = 32 * CHUNK;

/// The corners of input face `e` (3 or 4 nodes), `None` when a node is unknown.
fn face_corners(coords: &TagCoords, e: &[u64]) -> Option<[DVec3; 4]> {
    let mut p = [DVec3::ZERO; 4];
    for (x, &t) in p.iter_mut().zip(e) {
        *x = DVec3::from_array(coords.get(t)?);
    }
    Some(p)
}

/// Twice the vector area of the polygon `p[..k]` (Newell: a face's weight is its area).
fn face_normal(p: &[DVec3; 4], k: usize) -> DVec3 {
    let mut n = DVec3::ZERO;
    for j in 1..k - 1 {
        n += (p[j] - p[0]).cross(p[j + 1] - p[0]);
    }
    n
}

/// The faces of input surface `s` whose nodes all exist, in block order: each one's node
/// tags, corners and node count (3 or 4).
fn surface_faces<'m>(
    input: &'m Mesh,
    coords: &'m TagCoords,
    s: i32,
) -> impl Iterator<Item = (&'m [u64], [DVec3; 4], usize)> + 'm {
    input
        .element_blocks
        .iter()
        .filter(move |b| b.entity_tag == s && b.is_linear_face())
        .flat_map(move |b| {
            let k = b.nodes_per_element();
            (0..b.len()).filter_map(move |i| {
                let e = b.element(i);
                face_corners(coords, e).map(|p| (&e[..k], p, k))
            })
        })
}

/// The faces of input surface `s` whose nodes all exist, in block order.
fn input_faces(input: &Mesh, coords: &TagCoords, s: i32) -> Vec<Face> {
    surface_faces(input, coords, s)
        .map(|(_, p, k)| Face {
            corners: p,
            len: k as u8,
            normal: face_normal(&p, k),
        })
        .collect()
}

/// The area-weighted normals of the input faces of surface `s` at their nodes, normalized
/// ([`Normals`]).
fn input_normals(input: &Mesh, coords: &TagCoords, s: i32) -> Normals {
    let blocks = || {
        input
            .element_blocks
            .iter()
            .filter(|b| b.entity_tag == s && b.is_linear_face())
    };
    // each face's twice vector area, computed in parallel (`None`: a node is unknown, the
    // face does not count), then added at its nodes in face order (the same sums as one
    // thread); memory: a batch of faces at a time, not one normal per face of the surface
    let each_face = |f: &mut dyn FnMut(&[u64], DVec3)| {
        let mut batch: Vec<Option<DVec3>> = Vec::new();
        for b in blocks() {
            let k = b.nodes_per_element();
            for from in (0..b.len()).step_by(BATCH) {
                let to = (from + BATCH).min(b.len());
                batch.clear();
                batch.resize(to - from, None);
                batch
                    .par_chunks_mut(CHUNK)
                    .enumerate()
                    .for_each(|(c, out)| {
                        for (j, x) in out.iter_mut().enumerate() {
                            let i = from + c * CHUNK + j;
                            *x = face_corners(coords, b.element(i)).map(|p| face_normal(&p, k));
                        }
                    });
                for (i, n) in (from..to).zip(&batch) {
                    if let Some(n) = *n {
                        f(b.element(i), n);
                    }
                }
            }
        }
    };
    let (mut uses, mut max) = (0u64, 0u64);
    for b in blocks() {
        uses += b.nodes.len() as u64;
        max = b.nodes.iter().fold(max, |m, &t| m.max(t));
    }
    // speed: accumulated straight into a table when the surface's tags are dense enough
    // (a node is in about six triangles), else sorted pairs merged
    let at = if max <= 8 * uses + 1024 {
        let mut dense = vec![DVec3::ZERO; max as usize + 1];
        each_face(&mut |e, n| {
            for &t in e {
                dense[t as usize] += n;
            }
        });
        dense
            .par_chunks_mut(CHUNK)
            .for_each(|c| c.iter_mut().for_each(|n| *n = n.normalize_or_zero()));
        NodeNormals::Dense(dense)
    } else {
        let mut acc: Vec<(u64, DVec3)> = Vec::with_capacity(uses as usize);
        each_face(&mut |e, n| {
            for &t in e {
                acc.push((t, n));
            }
        });
        radix_sort_by_key(&mut acc, |x| x.0);
        let mut out: Vec<(u64, DVec3)> = Vec::with_capacity(acc.len() / 3 + 1);
        for (t, n) in acc {
            match out.last_mut() {
                Some(last) if last.0 == t => last.1 += n,
                _ => out.push((t, n)),
            }
        }
        for x in &mut out {
            x.1 = x.1.normalize_or_zero();
        }
        NodeNormals::Sorted(out)
    };
    // the wrapped nodes: a face turning WRAP_COS or more from the node's normal; and
    // whether every face has the first one's unit normal
    let mut wrapped = Vec::new();
    let mut first: Option<DVec3> = None;
    let mut planar = true;
    each_face(&mut |e, n| {
        let len = n.length();
        if len > 0.0 {
            let u = n / len;
            planar &= u.dot(*first.get_or_insert(u)) >= PLANAR_COS;
        }
        for &t in e {
            if len > 0.0
                && at
                    .get(t)
                    .is_some_and(|m| m != DVec3::ZERO && n.dot(m) <= WRAP_COS * len)
            {
                wrapped.push(t);
            }
        }
    });
    wrapped.sort_unstable();
    wrapped.dedup();
    Normals {
        at,
        wrapped,
        planar,
    }
}

/// One input face: its corners (3 or 4) and twice its vector area.
struct Face {
    corners: [DVec3; 4],
    len: u8,
    normal: DVec3,
}

/// Cosine above which two unit face normals count as the same ([`Normals::planar`]):
/// rounding only.
const PLANAR_COS: f64 = 1.0 - 1e-15;

/// Cosine of the turn (60°) from the mean normal of the faces a quad came from at which a
/// face at one of its nodes lies on another side of a sharp turn of the surface
/// ([`SourceFaces::normal`]).
const TURN_COS: f64 = 0.5;

/// The values of `pairs` (key below `len`, value) grouped by key, in their order (CSR): those
/// of key `k` are `around[start[k]..start[k + 1]]`.
fn grouped(len: usize, pairs: impl Iterator<Item = (usize, u32)> + Clone) -> (Vec<u32>, Vec<u32>) {
    let mut start = vec![0u32; len + 1];
    for (k, _) in pairs.clone() {
        start[k + 1] += 1;
    }
    for i in 0..len {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut around = vec![0u32; start[len] as usize];
    for (k, v) in pairs {
        around[fill[k] as usize] = v;
        fill[k] += 1;
    }
    (start, around)
}

/// The input faces of one surface by node, for the normal of the faces a quad came from
/// ([`SourceFaces::normal`]).
struct SourceFaces {
    /// The faces at each node.
    at: FacesAt,
    /// Each face's node count and unit normal (zero for a face of no area).
    faces: Vec<(u8, DVec3)>,
}

/// The faces at each node: by tag in a table when the tags are dense enough (those of
/// node tag `t` are `around[start[t]..start[t + 1]]`), else sorted by tag (`tags[i]` the
/// node of `around[i]`).
enum FacesAt {
    Dense { start: Vec<u32>, around: Vec<u32> },
    Sorted { tags: Vec<u64>, around: Vec<u32> },
}

impl SourceFaces {
    /// The faces of input surface `s` whose nodes all exist.
    fn new(input: &Mesh, coords: &TagCoords, s: i32) -> Self {
        let mut by_node = Vec::new();
        let mut faces = Vec::new();
        for (e, p, k) in surface_faces(input, coords, s) {
            for &t in e {
                by_node.push((t, faces.len() as u32));
            }
            faces.push((k as u8, face_normal(&p, k).normalize_or_zero()));
        }
        // speed: a table by tag when the tags are dense (as Gmsh writes them: a node is in
        // about six triangles), the faces of each node in face order
        let max = by_node.iter().map(|x| x.0).max().unwrap_or(0);
        let at = if max <= 8 * by_node.len() as u64 + 1024 {
            let (start, around) = grouped(
                max as usize + 1,
                by_node.iter().map(|&(t, f)| (t as usize, f)),
            );
            FacesAt::Dense { start, around }
        } else {
            radix_sort_by_key(&mut by_node, |x| x.0);
            FacesAt::Sorted {
                tags: by_node.iter().map(|x| x.0).collect(),
                around: by_node.iter().map(|x| x.1).collect(),
            }
        };
        SourceFaces { at, faces }
    }

    /// The faces at node `t`, in face order.
    fn at(&self, t: u64) -> &[u32] {
        match &self.at {
            FacesAt::Dense { start, around } => match usize::try_from(t) {
                Ok(t) if t + 1 < start.len() => {
                    &around[start[t] as usize..start[t + 1] as usize]
                }
                _ => &[],
            },
            FacesAt::Sorted { tags, around } => {
                let from = tags.partition_point(|&x| x < t);
                let to = from + tags[from..].iter().take_while(|&&x| x == t).count();
                &around[from..to]
            }
        }
    }

    /// The unit mean normal of the input faces at node `t` that quad `q` holds (all their
    /// nodes among the quad's): the side of the surface its corner at `t` is on where the
    /// surface wraps round `t`. `None` when the quad holds no face there (a node the run
    /// added is one of its corners); zero when those faces cancel out (the quad folds
    /// across its diagonal).
    fn held_at(&self, q: &[u64; 4], t: u64) -> Option<DVec3> {
        let mut held = self
            .at(t)
            .iter()
            .filter(|&&f| {
                let on = q.iter().filter(|&&v| self.at(v).contains(&f)).count();
                on == usize::from(self.faces[f as usize].0)
            })
            .peekable();
        held.peek()?;
        Some(held.map(|&f| self.faces[f as usize].1).sum::<DVec3>().normalize_or_zero())
    }

    /// The unit mean normal of the input faces quad `q` came from: those whose nodes are
    /// all among the quad's, else those sharing an edge's two nodes with it, else one
    /// node; `None` when no face has a node of the quad, when those normals cancel, or
    /// when a face at one of the quad's nodes turns [`TURN_COS`] or more from that mean
    /// (the faces lie on several sides of a sharp turn: no one normal stands for the quad,
    /// and its corners are measured at their own nodes).
    fn normal(&self, q: &[u64; 4]) -> Option<DVec3> {
        // the faces at the quad's nodes and how many of its nodes each has (speed: on the
        // stack up to 64 faces)
        let mut stack = [(0u32, 0u8); 64];
        let mut len = 0;
        let mut more: Vec<(u32, u8)> = Vec::new();
        for &t in q {
            for &f in self.at(t) {
                if let Some(x) = stack[..len].iter_mut().chain(more.iter_mut()).find(|x| x.0 == f) {
                    x.1 += 1;
                } else if len < stack.len() {
                    stack[len] = (f, 1);
                    len += 1;
                } else {
                    more.push((f, 1));
                }
            }
        }
        let shared = || stack[..len].iter().chain(more.iter());
        let sum = |keep: &dyn Fn(u8, u8) -> bool| -> DVec3 {
            shared()
                .filter(|&&(f, c)| keep(c, self.faces[f as usize].0))
                .map(|&(f, _)| self.faces[f as usize].1)
                .sum()
        };
        let levels: [&dyn Fn(u8, u8) -> bool; 3] = [&|c, k| c == k, &|c, _| c >= 2, &|c, _| c >= 1];
        let mean = levels
            .iter()
            .map(|keep| sum(*keep))
            .find(|n| *n != DVec3::ZERO)?
            .normalize_or_zero();
        let turns = shared()
            .any(|&(f, _)| self.faces[f as usize].1.dot(mean) <= TURN_COS);
        (mean != DVec3::ZERO && !turns).then_some(mean)
    }
}

/// The nearest input faces of one surface to a point (closest-point grid over the faces'
/// triangles).
struct Nearest {
    faces: Vec<Face>,
    /// Face of each triangle of `surface`.
    face_of: Vec<u32>,
    surface: crate::quality::locate::TriSurface,
    tie: f64,
}

impl Nearest {
    fn new(faces: Vec<Face>, tie: f64) -> Self {
        let mut points: Vec<DVec3> = Vec::new();
        let mut tris: Vec<[u32; 3]> = Vec::new();
        let mut face_of: Vec<u32> = Vec::new();
        for (f, face) in faces.iter().enumerate() {
            let first = points.len() as u32;
            points.extend_from_slice(&face.corners[..face.len as usize]);
            for j in 1..face.len as u32 - 1 {
                tris.push([first, first + j, first + j + 1]);
                face_of.push(f as u32);
            }
        }
        Nearest {
            faces,
            face_of,
            surface: crate::quality::locate::TriSurface::new(points, tris),
            tie,
        }
    }

    /// Distance from `p` to face `f` ([`triangle_distance`]).
    fn distance(&self, f: u32, p: DVec3) -> f64 {
        let face = &self.faces[f as usize];
        let c = &face.corners;
        (1..face.len as usize - 1)
            .map(|k| triangle_distance(p, [c[0], c[k], c[k + 1]]))
            .fold(f64::INFINITY, f64::min)
    }

    /// The unit summed normal of the faces nearest to `p` (every face within the ties of
    /// the nearest, by [`Nearest::distance`], wherever it is on the surface: where the
    /// surface lies over itself, the faces of both layers at `p` count, as the fuzz check
    /// and `tests/check_mesh.py` count them): `None` when the surface has no face, zero
    /// when the nearest faces cancel out.
    fn normal(&self, p: DVec3) -> Option<DVec3> {
        let hit = self.surface.closest(p)?;
        // every triangle that can be within the ties of the nearest face: the closest point
        // found is within rounding (far below this margin) of the nearest face's distance
        let reach = hit.point.distance(p) + 1e3 * self.tie;
        let mut near: Vec<u32> = Vec::with_capacity(32);
        self.surface.near(p, reach, &mut near);
        for t in near.iter_mut() {
            *t = self.face_of[*t as usize];
        }
        near.sort_unstable();
        near.dedup();
        let d: Vec<f64> = near.iter().map(|&f| self.distance(f, p)).collect();
        let best = d.iter().copied().fold(f64::INFINITY, f64::min);
        let n = near
            .iter()
            .zip(&d)
            .filter(|&(_, &df)| df <= best + self.tie)
            .map(|(&f, _)| self.faces[f as usize].normal)
            .sum::<DVec3>()
            .normalize_or_zero();
        Some(n)
    }
}

/// Distance from `p` to triangle `t`: inside its prism, the distance to its plane (not to
/// a closest point rebuilt from barycentric coordinates, whose rounding a far corner of a
/// sliver multiplies by its distance: a point inside such a triangle came out 3e-5 away
/// from it, beyond the ties of the nearest faces); else the distance to its nearest edge.
fn triangle_distance(p: DVec3, t: [DVec3; 3]) -> f64 {
    let bary = crate::quality::locate::plane_barycentric(p, t);
    let n = (t[1] - t[0]).cross(t[2] - t[0]);
    let n2 = n.length_squared();
    if bary.iter().all(|&x| x >= 0.0) && n2 > 0.0 {
        return n.dot(p - t[0]).abs() / n2.sqrt();
    }
    (0..3)
        .map(|k| crate::quality::locate::closest_on_segment(p, t[k], t[(k + 1) % 3]).distance(p))
        .fold(f64::INFINITY, f64::min)
}

/// Whether a quad bent across a sharp turn of a coarse curved surface passes the check
/// when it is valid (see the module doc), or the check also asks what the pipeline asks
/// of its quads first: every corner turning positively about the input normal at each of
/// the quad's other nodes too.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub(crate) enum Bent {
    /// Valid quads pass, bent or not (the definition the output keeps).
    Accepted,
    /// A bent quad fails: each corner must also turn positively about the input normal at
    /// every node of the quad the input has and does not wrap round (what the pipeline's
    /// rounds ask unless a job says otherwise).
    #[default]
    Refused,
}

/// The first defect of quad `q`, if any.
fn check_quad<'n>(
    coords: &TagCoords,
    normals: &Normals,
    nearest: &(dyn Fn() -> &'n Nearest + Sync),
    source: &(dyn Fn() -> &'n SourceFaces + Sync),
    q: [u64; 4],
    min_edge: f64,
    bent: Bent,
) -> Option<Defect> {
    let mut p = [DVec3::ZERO; 4];
    for k in 0..4 {
        let Some(c) = coords.get(q[k]) else {
            return Some(Defect::MissingNode(q[k]));
        };
        p[k] = DVec3::from_array(c);
        if q[..k].contains(&q[k]) {
            return Some(Defect::RepeatedNode(q[k]));
        }
    }
    for k in 0..4 {
        let len = (p[(k + 1) % 4] - p[k]).length();
        if len.is_nan() || len <= min_edge {
            return Some(Defect::ZeroLengthEdge { corner: k });
        }
    }
    let own = (p[2] - p[0]).cross(p[3] - p[1]).normalize_or_zero();
    // the input normal at each corner's node (`None`: a node the input lacks), and each
    // corner's two edges, its plane's normal `a × b` and its sine floor, read by both passes
    let at: [Option<DVec3>; 4] = std::array::from_fn(|k| normals.get(q[k]));
    let wraps: [bool; 4] = std::array::from_fn(|k| at[k].is_some() && normals.wraps(q[k]));
    let corners: [(DVec3, DVec3, DVec3, f64); 4] = std::array::from_fn(|k| {
        let a = p[(k + 1) % 4] - p[k];
        let b = p[(k + 3) % 4] - p[k];
        (a, b, a.cross(b), MIN_SINE * a.length() * b.length())
    });
    // the normal each corner is measured about
    let mut about = [DVec3::ZERO; 4];
    for (k, &(a, b, ab, floor)) in corners.iter().enumerate() {
        // a node the input lacks, or whose faces cancel out: the faces nearest to a point
        // inside the corner (the faces the quad lies on there); a wrapped node: the input
        // faces the quad holds there, else the same
        let n = match at[k] {
            Some(n) if !wraps[k] => n,
            known => {
                let held = known.and_then(|_| source().held_at(&q, q[k]));
                match held.or_else(|| nearest().normal(own_side(p[k], a, b))) {
                    Some(n) if n == DVec3::ZERO => return Some(Defect::NoNormal { corner: k }),
                    Some(n) => n,
                    None => own,
                }
            }
        };
        about[k] = n;
        let s = n.dot(ab);
        let c = a.dot(b);
        // α = atan2(s, c) is inside (ε, π − ε) exactly when s > |c| tan ε; and the corner
        // must not be seen edge-on (its plane about perpendicular to the surface, where s
        // and c are both rounding noise): s above MIN_SINE of |a| |b|
        let inside = s > c.abs() * *MIN_TAN && s > floor;
        if !inside {
            return Some(Defect::Corner {
                corner: k,
                degrees: s.atan2(c).to_degrees(),
            });
        }
    }
    // with bent quads refused, also about the input normals at the quad's other nodes: a
    // quad across a sharp turn of a coarse curved surface can have every corner positive
    // about its own node's normal and one of them reflex about the surface a neighbouring
    // node sees
    if bent == Bent::Refused {
        for (k, &(a, b, ab, floor)) in corners.iter().enumerate() {
            for n in at.iter().zip(wraps).filter(|x| !x.1).filter_map(|x| *x.0) {
                let s = n.dot(ab);
                if s.is_nan() || s <= floor {
                    return Some(Defect::Corner {
                        corner: k,
                        degrees: s.atan2(a.dot(b)).to_degrees(),
                    });
                }
            }
        }
    }
    // and about the mean normal of the input faces the quad came from, where one stands
    // for it (no wrapped node, no face at its nodes turning sharply from it): on a coarse
    // curved face, a quad holding an input triangle and a node far off its plane can have
    // a corner edge-on to that triangle and positive about every node's normal
    let from = match normals.planar || wraps.contains(&true) {
        true => None,
        false => source().normal(&q),
    };
    if let Some(n) = from {
        for (k, &(a, b, ab, floor)) in corners.iter().enumerate() {
            let s = n.dot(ab);
            if s.is_nan() || s <= floor {
                return Some(Defect::Corner {
                    corner: k,
                    degrees: s.atan2(a.dot(b)).to_degrees(),
                });
            }
        }
    }
    // and about its own normal (the scaled Jacobian at each corner)
    for (k, &(a, b, ab, _)) in corners.iter().enumerate() {
        let d = a.length() * b.length();
        let scaled = own.dot(ab) / d;
        if scaled.is_nan() || scaled <= *MIN_TAN {
            return Some(Defect::OwnJacobian { corner: k, scaled });
        }
    }
    // and, where no one normal of the faces it came from stands for it, its own normal
    // turns less than 90 degrees from the sum of those its corners are measured about: it
    // faces the input's way
    if from.is_none() {
        let s = own.dot(about.iter().sum::<DVec3>());
        // NaN fails too
        if s.is_nan() || s <= 0.0 {
            return Some(Defect::TurnedOver);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::testing::{node_block, one_surface};

    fn mesh(coords: &[[f64; 3]], etype_: u32, elems: &[&[u64]]) -> Mesh {
        let tags = (1..=coords.len() as u64).collect();
        one_surface(vec![node_block(2, tags, coords.to_vec())], etype_, elems)
    }

    const SQUARE: [[f64; 3]; 4] = [[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]];

    #[test]
    fn a_point_inside_a_sliver_with_a_far_corner_is_on_it() {
        // a sliver 2,134 long and 0.3 wide; the point lies inside it, 9.3e-6 of the way
        // from its short edge to the far corner: rebuilt from barycentric coordinates the
        // closest point is 3e-5 off, more than the nearest faces' ties at this extent
        let t = [
            DVec3::new(-1.29013427919, -2136.3674624461573, 0.0),
            DVec3::new(-1.246979603717471, -1.563662964936056, 0.0),
            DVec3::new(-0.9399999999999834, -1.628127059114755, 0.0),
        ];
        let p = DVec3::new(-1.1612056375674913, -1.601505323066991, 0.0);
        let (q, _) = crate::quality::locate::closest_on_triangle(p, t);
        assert!(q.distance(p) > 1e-6, "the rebuilt point: {}", q.distance(p));
        assert!(triangle_distance(p, t) < 1e-12, "{}", triangle_distance(p, t));
        // off the plane by 0.5, inside the prism: 0.5; beyond the short edge: to that edge
        assert!((triangle_distance(p + DVec3::Z * 0.5, t) - 0.5).abs() < 1e-12);
        let out = DVec3::new(-1.1, -1.0, 0.0);
        let e = (t[2] - t[1]).normalize();
        let to_edge = (out - t[1]) - e * (out - t[1]).dot(e);
        assert!((triangle_distance(out, t) - to_edge.length()).abs() < 1e-12);
    }

    #[test]
    fn a_point_over_two_layers_of_a_surface_counts_the_faces_of_both() {
        // a small triangle in z = 0 and, lying over it with no node in common, a larger one
        // turned over; a point inside both is on both, and the larger's normal outweighs
        let face = |c: [DVec3; 3]| Face {
            corners: [c[0], c[1], c[2], DVec3::ZERO],
            len: 3,
            normal: face_normal(&[c[0], c[1], c[2], DVec3::ZERO], 3),
        };
        let small = face([DVec3::ZERO, DVec3::X, DVec3::Y]);
        // 1e-12 below the small one: within the ties, though the small one is the closest
        let large = face([
            DVec3::new(-1.0, -1.0, -1e-12),
            DVec3::new(-1.0, 3.0, -1e-12),
            DVec3::new(3.0, -1.0, -1e-12),
        ]);
        let near = Nearest::new(vec![small, large], 1e-9);
        let n = near.normal(DVec3::new(0.2, 0.2, 0.0)).expect("faces");
        assert!((n - DVec3::NEG_Z).length() < 1e-12, "{n}");
        let lone = Nearest::new(vec![face([DVec3::ZERO, DVec3::X, DVec3::Y])], 1e-9);
        let n = lone.normal(DVec3::new(0.2, 0.2, 0.0)).expect("a face");
        assert!((n - DVec3::Z).length() < 1e-12, "{n}");
    }

    #[test]
    fn the_prepared_input_finds_what_the_one_call_finds() {
        // node 5, which the input does not have, takes its normal from the nearest faces
        let mut c = SQUARE.to_vec();
        c.push([0.5, 0.5, 0.0]);
        let input = mesh(&c, etype::TRI3, &[&[1, 2, 3], &[1, 3, 4]]);
        let reference = Reference::new(&input);
        for quads in [
            &[&[1, 2, 3, 4][..]][..],
            &[&[1, 4, 3, 2]],
            &[&[1, 2, 5, 4], &[2, 3, 4, 5]],
            &[&[1, 2, 4, 5], &[2, 3, 4, 5]],
            &[&[1, 2, 3, 2]],
        ] {
            let out = mesh(&c, etype::QUAD4, quads);
            assert_eq!(reference.invalid_quads(&out), invalid_quads(&input, &out));
        }
        assert_eq!(
            reference
                .invalid_quads(&mesh(&c, etype::QUAD4, &[&[1, 2, 4, 5]]))
                .len(),
            1
        );
    }

    #[test]
    fn the_nearest_faces_of_a_corner_do_not_depend_on_the_output_s_extent() {
        // triangle 2-1-4 folded back over 1-2-3 across edge 1-2, rising 5e-7 over it: a
        // point inside the quad's corner at node 5 lies on 1-2-3 and 7.5e-8 from 2-1-4,
        // far beyond the ties at the input's extent. An output with a node far away (a
        // spike another surface's smoothing moved) must not make the two faces tie and
        // cancel, whichever output a prepared reference checks first.
        let mut c = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 1.0, 5e-7],
            [0.1, 0.1, 0.0],
            [0.3, 0.1, 0.0],
            [0.3, 0.3, 0.0],
            [0.1, 0.3, 0.0],
        ];
        let input = mesh(&c, etype::TRI3, &[&[1, 2, 3], &[2, 1, 4]]);
        let near = mesh(&c, etype::QUAD4, &[&[5, 6, 7, 8]]);
        c.push([1000.0, 0.0, 0.0]);
        let far = mesh(&c, etype::QUAD4, &[&[5, 6, 7, 8]]);
        assert_eq!(invalid_quads(&input, &near), vec![]);
        assert_eq!(invalid_quads(&input, &far), vec![]);
        for order in [[&near, &far], [&far, &near]] {
            let reference = Reference::new(&input);
            for out in order {
                assert_eq!(reference.invalid_quads(out), vec![]);
            }
        }
        // turned over, the quad is caught in either output
        let turned = mesh(&c, etype::QUAD4, &[&[5, 8, 7, 6]]);
        assert_eq!(invalid_quads(&input, &turned).len(), 1);
    }

    #[test]
    fn a_corner_at_a_wrapped_node_is_measured_on_its_own_side() {
        // the unit square 1-2-3-4 (normal +z) with triangle 2-1-5 folded back over it across
        // edge 1-2: at nodes 1 and 2 the area-weighted normals turn 90 degrees or more from
        // the square's, so they stand for no side; the square's corners there are measured
        // about the faces nearest to a point inside them, the square's own
        let mut c = SQUARE.to_vec();
        c.push([0.5, 2.0, 0.5]);
        let input = mesh(&c, etype::TRI3, &[&[1, 2, 3], &[1, 3, 4], &[2, 1, 5]]);
        let reference = Reference::new(&input);
        let normals = &reference.surfaces[0].1.normals;
        assert!(normals.wraps(1) && normals.wraps(2));
        assert!(!normals.wraps(3) && !normals.wraps(4));
        // about node 1's own normal, (0, 1, 0), the corner there is seen edge-on
        assert!(normals.get(1).unwrap().dot(DVec3::Z).abs() < 1e-12);
        let square = mesh(&c, etype::QUAD4, &[&[1, 2, 3, 4]]);
        assert_eq!(reference.invalid_quads(&square), vec![]);
        // turned over, it is not valid about its own side either
        let turned = mesh(&c, etype::QUAD4, &[&[1, 4, 3, 2]]);
        let bad = reference.invalid_quads(&turned);
        assert_eq!(bad.len(), 1);
        assert!(matches!(bad[0].defect, Defect::Corner { .. }), "{:?}", bad[0]);
    }

    #[test]
    fn a_corner_at_a_fold_is_measured_about_the_faces_its_quad_holds() {
        // the unit square 1-2-3-4 (normal +z) with a larger triangle 2-1-5 folded flat over
        // it across edge 1-2: a point inside the square's corner at node 1 lies on both, and
        // the folded one outweighs the square's; the faces the quad holds at node 1 are the
        // square's, and they say which side its corner is on
        let mut c = SQUARE.to_vec();
        c.push([0.5, 10.0, 0.0]);
        let input = mesh(&c, etype::TRI3, &[&[1, 2, 3], &[1, 3, 4], &[2, 1, 5]]);
        let reference = Reference::new(&input);
        let normals = &reference.surfaces[0].1.normals;
        assert!(normals.wraps(1) && normals.wraps(2));
        let square = mesh(&c, etype::QUAD4, &[&[1, 2, 3, 4]]);
        assert_eq!(reference.invalid_quads(&square), vec![]);
        let turned = mesh(&c, etype::QUAD4, &[&[1, 4, 3, 2]]);
        assert_eq!(reference.invalid_quads(&turned).len(), 1);
        // a quad holding no input face at node 1 (node 6 is new) is measured at the point
        // inside its corner, where the folded triangle outweighs the square's
        c.push([1.0, 0.5, 0.0]);
        let split = mesh(&c, etype::QUAD4, &[&[1, 2, 6, 4]]);
        let bad = reference.invalid_quads(&split);
        assert_eq!(bad.len(), 1);
        assert_eq!(bad[0].node(), 1, "{:?}", bad[0]);
    }

    #[test]
    fn a_corner_at_a_new_node_is_measured_about_the_faces_its_quad_lies_on() {
        // triangle 1-2-3 in z = 0 (normal +z) and a larger one, 2-1-4, folded back over it
        // across edge 1-2 (its normal turns more than 90 degrees from +z); a quad split out
        // of triangle 1-2-3 (node 1, the midpoint 5 of edge 1-2, the centroid 6, the
        // midpoint 7 of edge 1-3) lies on it alone, though node 5 is as near to both
        // triangles, whose normals sum to one turned away from +z
        let c = [
            [0., 0., 0.],
            [1., 0., 0.],
            [0.5, 1., 0.],
            [0.5, 1.5, 0.9],
            [0.5, 0., 0.],
            [0.5, 1. / 3., 0.],
            [0.25, 0.5, 0.],
        ];
        let input = mesh(&c, etype::TRI3, &[&[1, 2, 3], &[2, 1, 4]]);
        let reference = Reference::new(&input);
        let sum = (DVec3::Z + DVec3::new(0., 0.9, -1.5)).normalize();
        let at_5 = DVec3::new(0., 1. / 3., 0.).cross(DVec3::new(-0.5, 0., 0.));
        assert!(at_5.dot(sum) < 0.0, "the corner is reflex about both faces' sum");
        let quad = mesh(&c, etype::QUAD4, &[&[1, 5, 6, 7]]);
        assert_eq!(reference.invalid_quads(&quad), vec![]);
        let turned = mesh(&c, etype::QUAD4, &[&[1, 7, 6, 5]]);
        assert_eq!(reference.invalid_quads(&turned).len(), 1);
    }

    #[test]
    fn a_new_node_where_the_nearest_faces_cancel_has_no_normal() {
        // triangle 1-3-5 lies on 1-2-3 turned over (node 5 is node 2's place): at nodes 1
        // and 3 the input's normals cancel, and so do the nearest faces' at node 6, which is
        // as near to either. A quad with such corners is not valid, whichever way it turns; on
        // one face alone it would be.
        let c = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.3, 0.6, 0.0],
        ];
        let folded = mesh(&c, etype::TRI3, &[&[1, 2, 3], &[1, 3, 5]]);
        let plain = mesh(&c, etype::TRI3, &[&[1, 2, 3], &[1, 3, 4]]);
        for quad in [[1, 2, 3, 6], [6, 3, 2, 1]] {
            let out = mesh(&c, etype::QUAD4, &[&quad]);
            let bad = invalid_quads(&folded, &out);
            assert_eq!(bad.len(), 1, "{quad:?}");
            assert!(
                matches!(bad[0].defect, Defect::NoNormal { .. }),
                "{}",
                bad[0]
            );
            assert!(
                bad[0].to_string().contains("folds back onto itself"),
                "{}",
                bad[0]
            );
        }
        let out = mesh(&c, etype::QUAD4, &[&[1, 2, 3, 6]]);
        assert!(invalid_quads(&plain, &out).is_empty());
    }

    #[test]
    fn a_square_is_valid_and_its_mirror_is_turned_over() {
        let input = mesh(&SQUARE, etype::TRI3, &[&[1, 2, 3], &[1, 3, 4]]);
        let ok = mesh(&SQUARE, etype::QUAD4, &[&[1, 2, 3, 4]]);
        assert!(invalid_quads(&input, &ok).is_empty());
        let flipped = mesh(&SQUARE, etype::QUAD4, &[&[1, 4, 3, 2]]);
        let bad = invalid_quads(&input, &flipped);
        assert_eq!(bad.len(), 1);
        assert!(matches!(bad[0].defect, Defect::Corner { degrees, .. } if degrees < 0.0));
        assert!(
            bad[0].to_string().contains("node 1 is not strictly"),
            "{}",
            bad[0]
        );
    }

    #[test]
    fn a_flat_corner_a_zero_edge_and_a_repeated_node_are_caught() {
        // node 5 on the edge 1-2: the quad 1 5 2 3 has a 180-degree corner at 5
        let mut c = SQUARE.to_vec();
        c.push([0.5, 0.0, 0.0]);
        let input = mesh(&c, etype::TRI3, &[&[1, 5, 3], &[5, 2, 3], &[1, 3, 4]]);
        let flat = mesh(&c, etype::QUAD4, &[&[1, 5, 2, 3]]);
        let bad = invalid_quads(&input, &flat);
        assert_eq!(bad.len(), 1);
        assert_eq!(bad[0].node(), 5);
        // node 6 on top of node 2
        c.push([1.0, 0.0, 0.0]);
        let zero = mesh(&c, etype::QUAD4, &[&[1, 2, 6, 3]]);
        assert!(matches!(
            invalid_quads(&input, &zero)[0].defect,
            Defect::ZeroLengthEdge { corner: 1 }
        ));
        let rep = mesh(&c, etype::QUAD4, &[&[1, 2, 3, 2]]);
        assert_eq!(
            invalid_quads(&input, &rep)[0].defect,
            Defect::RepeatedNode(2)
        );
    }

    #[test]
    fn corners_on_a_curved_surface_use_the_input_normal() {
        // a quad folded along its diagonal over a ridge, like two triangles of a cylinder:
        // valid about the input normals; the same quad reversed is not
        let c = [[0., 0., 0.], [1., 0., 0.3], [1., 1., 0.], [0., 1., 0.3]];
        let input = mesh(&c, etype::TRI3, &[&[1, 2, 3], &[1, 3, 4]]);
        assert!(invalid_quads(&input, &mesh(&c, etype::QUAD4, &[&[1, 2, 3, 4]])).is_empty());
        assert_eq!(
            invalid_quads(&input, &mesh(&c, etype::QUAD4, &[&[4, 3, 2, 1]])).len(),
            1
        );
    }

    /// The quads of `out` that fail the check with bent quads refused.
    fn bent_refused(input: &Mesh, out: &Mesh) -> Vec<BadQuad> {
        Reference::new(input).invalid_quads_on(out, &TagCoords::new(out), |_| true, Bent::Refused)
    }

    #[test]
    fn a_quad_bent_across_a_sharp_turn_is_valid_and_refused_only_where_bent_quads_are() {
        // two triangles hinged along 1-3, the second turned 120 degrees out of the first's
        // plane (a coarse curved face): every corner of the quad 1 2 3 4 turns positively
        // about its own node's normal, it faces the input's way and does not fold about
        // its own normal, so it is valid; but the corner at node 2 (in the first
        // triangle's plane) is reflex about node 4's (the second triangle's) normal, which
        // the check with bent quads refused catches
        let hinged = |fourth: [f64; 3]| {
            let c = [[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], fourth];
            let input = mesh(&c, etype::TRI3, &[&[1, 2, 3], &[1, 3, 4]]);
            let out = mesh(&c, etype::QUAD4, &[&[1, 2, 3, 4]]);
            (invalid_quads(&input, &out), bent_refused(&input, &out))
        };
        let (valid, refused) = hinged([0.75, 0.25, 0.612]);
        assert_eq!(valid, vec![]);
        assert_eq!(refused.len(), 1);
        assert_eq!(refused[0].node(), 2);
        assert!(matches!(refused[0].defect, Defect::Corner { degrees, .. } if degrees < 0.0));
        // a gentle turn (30 degrees) passes both
        assert_eq!(hinged([0.0670, 0.9330, 0.3536]), (vec![], vec![]));
    }

    #[test]
    fn a_saddle_quad_facing_away_from_the_input_normals_is_caught() {
        // a saddle quad 1 2 3 4 (its own normal +z), each node with a small input triangle
        // of its own whose normal points into the saddle and down: every corner turns
        // positively about its own node's normal and about the quad's own normal, but the
        // input normals sum to a downward normal (no one normal of the faces it came from
        // stands for it: they turn 60 degrees or more from their mean)
        let (h, e) = (1.0, 0.1);
        let mut c = vec![[1., 0., h], [0., 1., -h], [-1., 0., h], [0., -1., -h]];
        // per node, two edge vectors whose cross product is the wanted normal
        let sides = [
            ([0., e, 0.], [0.2 * e, 0., -e]),  // (-1, 0, -0.2)
            ([0., 0.2 * e, e], [e, 0., 0.]),   // (0, 1, -0.2)
            ([-0.2 * e, 0., -e], [0., e, 0.]), // (1, 0, -0.2)
            ([e, 0., 0.], [0., -0.2 * e, e]),  // (0, -1, -0.2)
        ];
        let mut tris: Vec<[u64; 3]> = Vec::new();
        for (k, (u, v)) in sides.iter().enumerate() {
            let p = c[k];
            let first = c.len() as u64 + 1;
            c.push([p[0] + u[0], p[1] + u[1], p[2] + u[2]]);
            c.push([p[0] + v[0], p[1] + v[1], p[2] + v[2]]);
            tris.push([k as u64 + 1, first, first + 1]);
        }
        let tris: Vec<&[u64]> = tris.iter().map(|t| &t[..]).collect();
        let input = mesh(&c, etype::TRI3, &tris);
        let out = mesh(&c, etype::QUAD4, &[&[1, 2, 3, 4]]);
        let normals = &Reference::new(&input).surfaces[0].1.normals;
        assert!((1..=4).all(|t| normals.get(t).is_some_and(|n| n.z < 0.0)));
        let bad = invalid_quads(&input, &out);
        assert_eq!(bad.len(), 1, "{bad:?}");
        assert_eq!(bad[0].defect, Defect::TurnedOver);
        assert!(bad[0].to_string().contains("faces away from the input surface"));
    }

    #[test]
    fn a_corner_edge_on_to_the_triangle_its_quad_came_from_is_caught() {
        // six triangles of a coarse curved face (from a random boolean part meshed at 0.6),
        // and a quad made of triangle 3 4 6 (node 6 moved a little) and node 8, which the
        // input does not have, on the curve through 3 and 4: its corner at node 4 turns
        // positively about the area-weighted normals at nodes 3, 4 and 6, but is seen
        // edge-on from the triangle 3 4 6 it came from (sine about -0.01)
        let c = [
            [1.410957, 1.376554, 1.039351],
            [1.47325, 1.090033, 1.039351],
            [1.555683, 1.191629, 1.039351],
            [1.528394, 1.319415, 1.039351],
            [1.377349, 1.33969, 0.6929],
            [1.543455, 1.255824, 0.926228],
            [1.519138, 1.127186, 0.863014],
            [1.469676, 1.347984, 1.039351],
        ];
        let tris: &[&[u64]] = &[&[2, 3, 7], &[6, 5, 7], &[3, 6, 7], &[3, 4, 6], &[4, 1, 6], &[1, 5, 6]];
        let input = mesh(&c, etype::TRI3, tris);
        let mut moved = c;
        moved[5] = [1.544434, 1.200998, 0.966642];
        let out = mesh(&moved, etype::QUAD4, &[&[6, 3, 4, 8]]);
        let reference = Reference::new(&input);
        let normals = &reference.surfaces[0].1.normals;
        let p = |t: usize| DVec3::from_array(moved[t - 1]);
        let corner = (p(8) - p(4)).cross(p(3) - p(4));
        for t in [3, 4, 6] {
            assert!(normals.get(t).unwrap().dot(corner) > 0.0, "node {t}");
        }
        let bad = reference.invalid_quads(&out);
        assert_eq!(bad.len(), 1);
        assert_eq!(bad[0].node(), 4);
        assert!(matches!(bad[0].defect, Defect::Corner { degrees, .. } if degrees < 0.0));
        // the same quad with node 8 where the triangle's plane meets the curve is valid
        let mut fixed = moved;
        fixed[7] = [1.47, 1.36, 1.02];
        assert_eq!(reference.invalid_quads(&mesh(&fixed, etype::QUAD4, &[&[6, 3, 4, 8]])), vec![]);
    }

    #[test]
    fn a_quad_folded_about_its_own_normal_is_caught() {
        // a quad whose corners all turn positively about the input's normal (+z, a flat
        // square of two triangles), bent so far out of that plane that about its own
        // normal (the cross product of its diagonals) the corner at node 1 folds: what
        // Gmsh's minSJ sees as a negative Jacobian
        let input = mesh(&SQUARE, etype::TRI3, &[&[1, 2, 3], &[1, 3, 4]]);
        let bent = [
            [-0.08, 0.16, -1.61],
            [0.99, -0.15, 0.18],
            [1.1, 1.17, -1.52],
            [0.09, 0.8, -0.78],
        ];
        let p = bent.map(DVec3::from_array);
        for k in 0..4 {
            let (a, b) = (p[(k + 1) % 4] - p[k], p[(k + 3) % 4] - p[k]);
            assert!(a.cross(b).z > 0.3 * a.length() * b.length(), "corner {k}");
        }
        let sj = crate::quality::view::quad4_scaled_jacobian(&p);
        assert!(sj < -0.1, "{sj}");
        let bad = invalid_quads(&input, &mesh(&bent, etype::QUAD4, &[&[1, 2, 3, 4]]));
        assert_eq!(bad.len(), 1, "{bad:?}");
        assert!(
            matches!(bad[0].defect, Defect::OwnJacobian { scaled, .. } if (scaled - sj).abs() < 1e-12),
            "{:?}",
            bad[0].defect
        );
        assert!(
            bad[0].to_string().contains("folds over itself"),
            "{}",
            bad[0]
        );
        // the same bend, milder, passes
        let mild = bent.map(|[x, y, z]| [x, y, 0.2 * z]);
        assert!(invalid_quads(&input, &mesh(&mild, etype::QUAD4, &[&[1, 2, 3, 4]])).is_empty());
    }
}
