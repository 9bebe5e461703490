//! The in-memory mesh model that every stage between reading and writing works on.
//!
//! The model mirrors MSH 4.1, the richer of the two formats: entities by dimension with
//! their physical groups and bounding entities, node blocks per entity and element blocks
//! per (entity, element type). MSH 2.2 files are lifted into it by the reader (entities are
//! derived from elementary tags, see "Reading MSH 2.x" in [`crate::msh`]).
//!
//! **Invariant:** node and element tags are kept exactly as read (sparse and unordered tags
//! are legal); a stage that creates nodes or elements gives them fresh tags above the current
//! maximum ([`Mesh::max_node_tag`], [`Mesh::max_element_tag`]). Only the last step of
//! [`crate::quadrangulate`], the renumbering, changes tags: it numbers the result 1..N
//! (unless [`crate::Options::keep_tags`]).
//!
//! **Invariant:** this module does no I/O; only `msh` and the CLI touch files.

mod curves;
mod nodes;
#[cfg(test)]
pub(crate) mod testing;

pub(crate) use curves::{classified_curve, lined_curves, mean_params};
pub(crate) use nodes::{NodeIds, NodeTable, TagCoords};
pub use nodes::{NodeIndex, NodeRef};

/// Sentinel for "no index" in the crate's `u32` index arrays (no node, no triangle, no
/// neighbour); `matching` has its own of the same value.
pub(crate) const NONE: u32 = u32::MAX;

/// Which MSH variant a mesh was read from, and which one to write.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MshFormat {
    /// Major.minor version of the file format.
    pub version: MshVersion,
    /// Binary (`true`) or ASCII (`false`) encoding.
    pub binary: bool,
}

/// MSH file format versions the crate reads. Writing supports `V22` and `V41` only.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MshVersion {
    /// MSH 2.x (2.0, 2.1, 2.2): flat node and element lists, physical tags per element.
    V2 {
        /// Minor version as written (0, 1 or 2).
        minor: u8,
    },
    /// MSH 4.0: entity blocks, older block header layout.
    V40,
    /// MSH 4.1: entity blocks (the default written by Gmsh 4).
    V41,
}

impl MshVersion {
    /// The version for one of Gmsh's `-format` names (`msh41`, `msh4`, `msh22`, `msh2`).
    /// Writing supports 4.1 and 2.2 only, so `msh40` is refused (`None`).
    pub fn from_gmsh_name(name: &str) -> Option<MshVersion> {
        match name.to_ascii_lowercase().as_str() {
            "msh41" | "msh4" | "msh" => Some(MshVersion::V41),
            "msh22" | "msh2" => Some(MshVersion::V2 { minor: 2 }),
            _ => None,
        }
    }
}

impl std::fmt::Display for MshVersion {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MshVersion::V2 { minor } => write!(f, "2.{minor}"),
            MshVersion::V40 => f.write_str("4.0"),
            MshVersion::V41 => f.write_str("4.1"),
        }
    }
}

impl std::fmt::Display for MshFormat {
    /// `MSH 4.1 binary`, `MSH 2.2 ASCII`, ...
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let enc = if self.binary { "binary" } else { "ASCII" };
        write!(f, "MSH {} {enc}", self.version)
    }
}

/// A physical group name, from `$PhysicalNames`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PhysicalName {
    /// Dimension of the group (0..=3).
    pub dim: i32,
    /// Physical tag.
    pub tag: i32,
    /// The name, without quotes.
    pub name: String,
}

/// A model entity (point, curve, surface or volume) from `$Entities`, or derived.
#[derive(Debug, Clone, PartialEq)]
pub struct Entity {
    /// Dimension 0..=3.
    pub dim: i32,
    /// Entity tag, unique within its dimension.
    pub tag: i32,
    /// Bounding box `[min_x, min_y, min_z, max_x, max_y, max_z]`; for points the box is
    /// degenerate (min = max = the point's coordinates).
    pub bbox: [f64; 6],
    /// Physical tags of the groups this entity belongs to (may be empty).
    pub physical_tags: Vec<i32>,
    /// Signed tags of the bounding entities of dimension `dim - 1` (empty for points).
    pub bounding: Vec<i32>,
}

/// Nodes classified on one entity, in file order.
#[derive(Debug, Clone, PartialEq)]
pub struct NodeBlock {
    /// Dimension of the classifying entity.
    pub entity_dim: i32,
    /// Tag of the classifying entity.
    pub entity_tag: i32,
    /// Node tags, as written.
    pub tags: Vec<u64>,
    /// Coordinates, one per tag.
    pub coords: Vec<[f64; 3]>,
    /// Parametric coordinates when the block is parametric: `entity_dim` values per node
    /// (u for curves, u v for surfaces), flattened. `None` for non-parametric blocks.
    pub params: Option<Vec<f64>>,
}

/// Elements of one type classified on one entity, in file order.
#[derive(Debug, Clone, PartialEq)]
pub struct ElementBlock {
    /// Dimension of the classifying entity.
    pub entity_dim: i32,
    /// Tag of the classifying entity.
    pub entity_tag: i32,
    /// Gmsh element type code (1 line2, 2 tri3, 3 quad4, ...). See [`element_node_count`].
    pub element_type: u32,
    /// Element tags, as written.
    pub tags: Vec<u64>,
    /// Node tags of every element, flattened (`element_node_count(element_type)` per element).
    pub nodes: Vec<u64>,
    /// MSH 2.x partition tags per element (tags after the elementary tag), kept so they can be
    /// written back. `None` when the input had none.
    pub partitions: Option<Vec<Vec<i32>>>,
}

impl ElementBlock {
    /// Number of nodes per element of this block.
    pub fn nodes_per_element(&self) -> usize {
        element_node_count(self.element_type).unwrap_or(0)
    }
    /// Number of elements in this block.
    pub fn len(&self) -> usize {
        self.tags.len()
    }
    /// True when the block holds no element.
    pub fn is_empty(&self) -> bool {
        self.tags.is_empty()
    }
    /// Node tags of element `i`.
    pub fn element(&self, i: usize) -> &[u64] {
        let k = self.nodes_per_element();
        &self.nodes[i * k..(i + 1) * k]
    }
    /// True when the block's arrays agree: one node list of the type's size per element
    /// (not checkable for a type of unknown size) and, when given, one partition list per
    /// element. Stages refuse a block that is not, as
    /// [`MalformedBlock`](crate::recombine::RecombineError::MalformedBlock)
    /// (`recombine::check_block`).
    pub(crate) fn is_well_formed(&self) -> bool {
        let k = self.nodes_per_element();
        (k == 0 || self.nodes.len() == self.len() * k)
            && self
                .partitions
                .as_ref()
                .is_none_or(|p| p.len() == self.len())
    }
    /// True for a block of 3-node triangles or 4-node quads on a surface (entity dimension
    /// 2): the faces recombination, its checks and the periodic mapping work on.
    pub(crate) fn is_linear_face(&self) -> bool {
        self.entity_dim == 2
            && (self.element_type == etype::TRI3 || self.element_type == etype::QUAD4)
    }
}

/// One `$Periodic` link: the nodes of entity (`dim`, `tag`) are images of those of `master_tag`.
#[derive(Debug, Clone, PartialEq)]
pub struct PeriodicLink {
    /// Dimension of both entities.
    pub dim: i32,
    /// Slave entity tag.
    pub tag: i32,
    /// Master entity tag.
    pub master_tag: i32,
    /// The 16 affine transform values, when present.
    pub affine: Option<Vec<f64>>,
    /// `(node, master_node)` pairs.
    pub node_pairs: Vec<(u64, u64)>,
}

/// A section the crate does not interpret (e.g. `$Comments`), kept byte for byte to be
/// written back. `body` is everything between the `$Name` line and the `$EndName` line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RawSection {
    /// Section name without the `$` (e.g. `Comments`).
    pub name: String,
    /// Raw bytes between the header line and the end line.
    pub body: Vec<u8>,
    /// Index of the interpreted section this one followed in the input (0 = before
    /// `$MeshFormat`), so it can be written back at the same place.
    pub position: SectionPosition,
}

/// Where a kept raw section sits relative to the interpreted sections.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum SectionPosition {
    /// Before `$MeshFormat`.
    BeforeFormat,
    /// After the mesh sections, or between them (written at the end).
    AfterMesh,
}

/// A post-processing data section (`$NodeData`, `$ElementData`, `$ElementNodeData`): its
/// validity depends on node and element tags, so stages that change elements must call
/// [`Mesh::invalidate_element_data`].
#[derive(Debug, Clone, PartialEq)]
pub struct DataSection {
    /// `NodeData`, `ElementData` or `ElementNodeData`.
    pub kind: DataKind,
    /// The raw section body, as read (ASCII or binary).
    pub body: Vec<u8>,
    /// `None`: `body` is encoded as the file the mesh was read from (written only into a
    /// format of the same encoding). `Some(binary)`: a section this crate made, encoded
    /// binary or ASCII as said; such a body is the same in MSH 2.2 and 4.1 (binary
    /// entries are a 4-byte tag and 8-byte values), so it is written into any version
    /// with that encoding.
    pub encoded_binary: Option<bool>,
}

/// The three kinds of post-processing data sections.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DataKind {
    /// `$NodeData`: values per node tag.
    Node,
    /// `$ElementData`: values per element tag.
    Element,
    /// `$ElementNodeData`: values per element node.
    ElementNode,
}

impl DataKind {
    /// The section name without `$`.
    pub fn section_name(self) -> &'static str {
        match self {
            DataKind::Node => "NodeData",
            DataKind::Element => "ElementData",
            DataKind::ElementNode => "ElementNodeData",
        }
    }
}

/// A whole mesh: what an MSH file holds.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Mesh {
    /// The format the mesh was read from (`None` for meshes built in memory).
    pub format: Option<MshFormat>,
    /// `$PhysicalNames`, in file order.
    pub physical_names: Vec<PhysicalName>,
    /// Entities by dimension: `entities[d]` holds the entities of dimension `d`.
    pub entities: [Vec<Entity>; 4],
    /// True when the input had an `$Entities` section (always true for 4.x).
    pub has_entities_section: bool,
    /// Node blocks in file order.
    pub node_blocks: Vec<NodeBlock>,
    /// Element blocks in file order.
    pub element_blocks: Vec<ElementBlock>,
    /// `$Periodic` links.
    pub periodic: Vec<PeriodicLink>,
    /// Sections kept verbatim (`$Comments`, unknown sections).
    pub raw_sections: Vec<RawSection>,
    /// Post-processing data sections (kept while valid).
    pub data_sections: Vec<DataSection>,
    /// Warnings produced while reading or transforming (printed by the CLI).
    pub warnings: Vec<String>,
}

impl Mesh {
    /// The entity of dimension `dim` and tag `tag`, if any.
    pub fn entity(&self, dim: i32, tag: i32) -> Option<&Entity> {
        usize::try_from(dim)
            .ok()
            .and_then(|d| self.entities.get(d))
            .and_then(|v| v.iter().find(|e| e.tag == tag))
    }

    /// Total number of nodes.
    pub fn node_count(&self) -> usize {
        self.node_blocks.iter().map(|b| b.tags.len()).sum()
    }

    /// Total number of elements.
    pub fn element_count(&self) -> usize {
        self.element_blocks.iter().map(|b| b.tags.len()).sum()
    }

    /// Number of elements of MSH type `element_type` (e.g. [`etype::TRI3`]), over all
    /// blocks.
    pub fn count_elements(&self, element_type: u32) -> usize {
        self.element_blocks
            .iter()
            .filter(|b| b.element_type == element_type)
            .map(|b| b.tags.len())
            .sum()
    }

    /// Largest node tag (0 when there are no nodes).
    pub fn max_node_tag(&self) -> u64 {
        self.node_blocks
            .iter()
            .flat_map(|b| b.tags.iter().copied())
            .max()
            .unwrap_or(0)
    }

    /// Largest element tag (0 when there are no elements).
    pub fn max_element_tag(&self) -> u64 {
        self.element_blocks
            .iter()
            .flat_map(|b| b.tags.iter().copied())
            .max()
            .unwrap_or(0)
    }

    /// The tags of the surfaces (entity dimension 2) having an element block for which `keep`
    /// holds, sorted and without repeats.
    pub(crate) fn sorted_surfaces(&self, keep: impl Fn(&ElementBlock) -> bool) -> Vec<i32> {
        let mut tags: Vec<i32> = self
            .element_blocks
            .iter()
            .filter(|b| b.entity_dim == 2 && keep(b))
            .map(|b| b.entity_tag)
            .collect();
        tags.sort_unstable();
        tags.dedup();
        tags
    }

    /// A map from node tag to coordinates, for stages that look nodes up by tag.
    pub fn node_index(&self) -> NodeIndex {
        NodeIndex::new(self)
    }

    /// Name of physical group (`dim`, `tag`), if `$PhysicalNames` gives one.
    pub fn physical_name(&self, dim: i32, tag: i32) -> Option<&str> {
        self.physical_names
            .iter()
            .find(|p| p.dim == dim && p.tag == tag)
            .map(|p| p.name.as_str())
    }

    /// Drops `$ElementData`/`$ElementNodeData` sections (element tags changed) and records a
    /// warning saying so. `$NodeData` stays valid while node tags are kept.
    pub fn invalidate_element_data(&mut self) {
        let before = self.data_sections.len();
        self.data_sections.retain(|d| d.kind == DataKind::Node);
        let dropped = before - self.data_sections.len();
        if dropped > 0 {
            self.warnings.push(format!(
                "dropped {dropped} $ElementData/$ElementNodeData section(s): elements changed, their values no longer apply"
            ));
        }
    }
}

/// Every element type code Gmsh 4.15 defines with a fixed node count:
/// `(type code, dimension, nodes per element)`, generated from
/// `gmsh.model.mesh.getElementProperties`. Polygons/polyhedra (variable size) are absent.
pub const ELEMENT_TYPES: &[(u32, i32, usize)] = &[
    (1, 1, 2),     // Line 2
    (2, 2, 3),     // Triangle 3
    (3, 2, 4),     // Quadrilateral 4
    (4, 3, 4),     // Tetrahedron 4
    (5, 3, 8),     // Hexahedron 8
    (6, 3, 6),     // Prism 6
    (7, 3, 5),     // Pyramid 5
    (8, 1, 3),     // Line 3
    (9, 2, 6),     // Triangle 6
    (10, 2, 9),    // Quadrilateral 9
    (11, 3, 10),   // Tetrahedron 10
    (12, 3, 27),   // Hexahedron 27
    (13, 3, 18),   // Prism 18
    (14, 3, 14),   // Pyramid 14
    (15, 0, 1),    // Point
    (16, 2, 8),    // Quadrilateral 8
    (17, 3, 20),   // Hexahedron 20
    (18, 3, 15),   // Prism 15
    (19, 3, 13),   // Pyramid 13
    (20, 2, 9),    // Triangle 9
    (21, 2, 10),   // Triangle 10
    (22, 2, 12),   // Triangle 12
    (23, 2, 15),   // Triangle 15
    (24, 2, 15),   // Triangle 15I
    (25, 2, 21),   // Triangle 21
    (26, 1, 4),    // Line 4
    (27, 1, 5),    // Line 5
    (28, 1, 6),    // Line 6
    (29, 3, 20),   // Tetrahedron 20
    (30, 3, 35),   // Tetrahedron 35
    (31, 3, 56),   // Tetrahedron 56
    (32, 3, 22),   // Tetrahedron 22
    (33, 3, 28),   // Tetrahedron 28
    (36, 2, 16),   // Quadrilateral 16
    (37, 2, 25),   // Quadrilateral 25
    (38, 2, 36),   // Quadrilateral 36
    (39, 2, 12),   // Quadrilateral 12
    (40, 2, 16),   // Quadrilateral 16I
    (41, 2, 20),   // Quadrilateral 20
    (42, 2, 28),   // Triangle 28
    (43, 2, 36),   // Triangle 36
    (44, 2, 45),   // Triangle 45
    (45, 2, 55),   // Triangle 55
    (46, 2, 66),   // Triangle 66
    (47, 2, 49),   // Quadrilateral 49
    (48, 2, 64),   // Quadrilateral 64
    (49, 2, 81),   // Quadrilateral 81
    (50, 2, 100),  // Quadrilateral 100
    (51, 2, 121),  // Quadrilateral 121
    (52, 2, 18),   // Triangle 18
    (53, 2, 21),   // Triangle 21I
    (54, 2, 24),   // Triangle 24
    (55, 2, 27),   // Triangle 27
    (56, 2, 30),   // Triangle 30
    (57, 2, 24),   // Quadrilateral 24
    (58, 2, 28),   // Quadrilateral 28
    (59, 2, 32),   // Quadrilateral 32
    (60, 2, 36),   // Quadrilateral 36I
    (61, 2, 40),   // Quadrilateral 40
    (62, 1, 7),    // Line 7
    (63, 1, 8),    // Line 8
    (64, 1, 9),    // Line 9
    (65, 1, 10),   // Line 10
    (66, 1, 11),   // Line 11
    (71, 3, 84),   // Tetrahedron 84
    (72, 3, 120),  // Tetrahedron 120
    (73, 3, 165),  // Tetrahedron 165
    (74, 3, 220),  // Tetrahedron 220
    (75, 3, 286),  // Tetrahedron 286
    (79, 3, 34),   // Tetrahedron 34
    (80, 3, 40),   // Tetrahedron 40
    (81, 3, 46),   // Tetrahedron 46
    (82, 3, 52),   // Tetrahedron 52
    (83, 3, 58),   // Tetrahedron 58
    (84, 1, 1),    // Line 1
    (85, 2, 1),    // Triangle 1
    (86, 2, 1),    // Quadrilateral 1
    (87, 3, 1),    // Tetrahedron 1
    (88, 3, 1),    // Hexahedron 1
    (89, 3, 1),    // Prism 1
    (92, 3, 64),   // Hexahedron 64
    (93, 3, 125),  // Hexahedron 125
    (94, 3, 216),  // Hexahedron 216
    (95, 3, 343),  // Hexahedron 343
    (96, 3, 512),  // Hexahedron 512
    (97, 3, 729),  // Hexahedron 729
    (98, 3, 1000), // Hexahedron 1000
    (99, 3, 32),   // Hexahedron 32
    (100, 3, 44),  // Hexahedron 44
    (101, 3, 56),  // Hexahedron 56
    (102, 3, 68),  // Hexahedron 68
    (103, 3, 80),  // Hexahedron 80
    (104, 3, 92),  // Hexahedron 92
    (105, 3, 104), // Hexahedron 104
    (118, 3, 30),  // Pyramid 30
    (119, 3, 55),  // Pyramid 55
    (120, 3, 91),  // Pyramid 91
    (121, 3, 140), // Pyramid 140
    (122, 3, 204), // Pyramid 204
    (123, 3, 285), // Pyramid 285
    (124, 3, 385), // Pyramid 385
    (125, 3, 21),  // Pyramid 21
    (126, 3, 29),  // Pyramid 29
    (127, 3, 37),  // Pyramid 37
    (128, 3, 45),  // Pyramid 45
    (129, 3, 53),  // Pyramid 53
    (130, 3, 61),  // Pyramid 61
    (131, 3, 69),  // Pyramid 69
    (132, 3, 1),   // Pyramid 1
    (137, 3, 16),  // Tetrahedron 16
];

/// Largest type code in [`ELEMENT_TYPES`] plus one.
const TYPE_SLOTS: usize = 138;

/// `TYPE_INDEX[code]` = index of `code` in [`ELEMENT_TYPES`] + 1 (0 = unknown): a direct
/// lookup, since element types are queried for every element read.
const TYPE_INDEX: [u8; TYPE_SLOTS] = {
    let mut t = [0u8; TYPE_SLOTS];
    let mut i = 0;
    while i < ELEMENT_TYPES.len() {
        t[ELEMENT_TYPES[i].0 as usize] = (i + 1) as u8;
        i += 1;
    }
    t
};

fn element_type_entry(element_type: u32) -> Option<&'static (u32, i32, usize)> {
    let slot = *TYPE_INDEX.get(element_type as usize)?;
    ELEMENT_TYPES.get((slot as usize).checked_sub(1)?)
}

/// Number of nodes of a Gmsh element type, or `None` for an unknown type code.
///
/// Covers every fixed-size type code Gmsh defines, including high-order and incomplete
/// elements, so that elements we never recombine are still read and kept.
pub fn element_node_count(element_type: u32) -> Option<usize> {
    element_type_entry(element_type).map(|e| e.2)
}

/// Dimension of a Gmsh element type (0 point, 1 line, 2 surface, 3 volume), or `None` for
/// an unknown type code.
pub fn element_dim(element_type: u32) -> Option<i32> {
    element_type_entry(element_type).map(|e| e.1)
}

/// Gmsh element type codes the recombination stages care about.
pub mod etype {
    /// 2-node line.
    pub const LINE2: u32 = 1;
    /// 3-node triangle.
    pub const TRI3: u32 = 2;
    /// 4-node quadrangle.
    pub const QUAD4: u32 = 3;
    /// 1-node point.
    pub const POINT: u32 = 15;
    /// 6-node second-order triangle.
    pub const TRI6: u32 = 9;
    /// 3-node second-order line.
    pub const LINE3: u32 = 8;
    /// 9-node second-order quadrangle.
    pub const QUAD9: u32 = 10;
    /// 8-node second-order (serendipity) quadrangle.
    pub const QUAD8: u32 = 16;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn format_names_and_display() {
        assert_eq!(MshVersion::from_gmsh_name("msh41"), Some(MshVersion::V41));
        assert_eq!(
            MshVersion::from_gmsh_name("MSH22"),
            Some(MshVersion::V2 { minor: 2 })
        );
        assert_eq!(MshVersion::from_gmsh_name("msh40"), None);
        let f = MshFormat {
            version: MshVersion::V2 { minor: 0 },
            binary: true,
        };
        assert_eq!(f.to_string(), "MSH 2.0 binary");
    }

    #[test]
    fn type_lookup_matches_the_table_and_rejects_unknown_codes() {
        for &(code, dim, n) in ELEMENT_TYPES {
            assert_eq!(element_node_count(code), Some(n), "type {code}");
            assert_eq!(element_dim(code), Some(dim), "type {code}");
        }
        for code in [0, 34, 90, 91, 136, 138, 1000, u32::MAX] {
            assert_eq!(element_node_count(code), None, "type {code}");
        }
        assert!(ELEMENT_TYPES.windows(2).all(|w| w[0].0 < w[1].0));
    }
}
