//! Output numbered as Gmsh numbers it: node tags 1..N and element tags 1..M, no gaps.
//!
//! The stages keep every tag they can and give new nodes and elements tags above the
//! maximum, so a result has gaps where nodes and elements were removed (two triangles make
//! one quad; the optimizer collapses nodes) and tags beyond the count. Gmsh's own files are
//! numbered without gaps, and readers rely on it (DOLFINx's `read_from_msh` and
//! `model_to_mesh` assert that the node tags are exactly 1..N). [`renumber`] closes the
//! gaps, last of [`crate::quadrangulate`] unless [`crate::Options::keep_tags`] is set.
//!
//! The renumbering is the rank of each tag among the tags in use (nodes and elements
//! separately): it keeps the order of the tags, so a tag below the first gap keeps its
//! value, new nodes and elements still follow the kept ones, and a mesh already numbered
//! 1..N is left exactly as it is. One exception, as in Gmsh's own numbering: the nodes no
//! element of a physical group uses (no element at all, when there is no group: a dropped
//! volume's nodes; the centre point of a circle, a point or curve outside every group) come
//! after all the others, in the order of their tags (Gmsh leaves them out of its files
//! unless `Mesh.SaveAll`, its MSH 2 reader drops nodes no element uses, and DOLFINx reads
//! only the physical groups' elements and fails on such a node before a used one). Everything that names a node or element tag follows:
//! element node lists, `$Periodic` node pairs and the `$NodeData`, `$ElementData` and
//! `$ElementNodeData` sections. Entities and physical groups name entity tags, which do not
//! change.
//!
//! **Invariant:** after [`renumber`], the node tags in use are exactly 1..N and the element
//! tags 1..M (a tag repeated in the input stays repeated: both copies get the same new tag),
//! and for any two tags a < b before, new(a) < new(b) after, except that a node no physical
//! group's element uses comes after every node one uses.

use std::collections::{HashMap, HashSet};

use rayon::prelude::*;
use serde::Serialize;

use crate::mesh::{DataKind, Mesh};

/// What the renumbering of nodes and elements changed.
#[derive(Debug, Clone, Default, Serialize)]
pub struct RenumberReport {
    /// Nodes whose tag changed.
    pub nodes_changed: usize,
    /// Elements whose tag changed.
    pub elements_changed: usize,
    /// Old → new tags of the nodes and elements that were in the input, when asked for
    /// ([`crate::Options::tag_map`]).
    pub map: Option<TagMap>,
    /// What could not follow the renumbering (a data section dropped, node tags kept).
    pub warnings: Vec<String>,
}

/// Input tag → output tag, for every node and element of the input still in the output
/// (a quad carries the tag of one of its triangles, so its entry maps that triangle's tag),
/// ascending by input tag.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize)]
pub struct TagMap {
    /// `(input tag, output tag)` of each kept node.
    pub nodes: Vec<(u64, u64)>,
    /// `(input tag, output tag)` of each kept element.
    pub elements: Vec<(u64, u64)>,
}

/// The largest node and element tags of a mesh: those at most these are the input's in
/// the [`TagMap`] (new nodes and elements get tags above them).
#[derive(Debug, Clone, Copy)]
pub struct InputTags {
    /// Largest node tag of the input.
    pub max_node: u64,
    /// Largest element tag of the input.
    pub max_element: u64,
}

impl InputTags {
    /// The largest tags of `mesh`.
    pub fn of(mesh: &Mesh) -> InputTags {
        InputTags {
            max_node: mesh.max_node_tag(),
            max_element: mesh.max_element_tag(),
        }
    }
}

/// Tags in use in their new order (sorted without repeats, those `last` holds for moved
/// behind the others); the new tag of `order[i]` is i + 1.
struct Ranks {
    /// The tags in use, sorted.
    sorted: Vec<u64>,
    /// The tags in their new order.
    order: Vec<u64>,
    /// `dense[t]` = new tag of `t` (0: not in use), when the tags are compact enough
    dense: Vec<u64>,
    /// tag → new tag otherwise
    sparse: HashMap<u64, u64>,
}

impl Ranks {
    fn new(mut tags: Vec<u64>, last: impl Fn(u64) -> bool) -> Ranks {
        tags.par_sort_unstable();
        tags.dedup();
        let (first, moved): (Vec<u64>, Vec<u64>) = tags.iter().partition(|&&t| !last(t));
        let order = if moved.is_empty() {
            first
        } else {
            [first, moved].concat()
        };
        let max = tags.last().copied().unwrap_or(0);
        let mut r = Ranks {
            sorted: tags,
            order,
            dense: Vec::new(),
            sparse: HashMap::new(),
        };
        if max <= (4 * r.sorted.len() as u64).max(1024) {
            r.dense = vec![0u64; max as usize + 1];
            for (i, &t) in r.order.iter().enumerate() {
                r.dense[t as usize] = i as u64 + 1;
            }
        } else {
            r.sparse = r
                .order
                .iter()
                .enumerate()
                .map(|(i, &t)| (t, i as u64 + 1))
                .collect();
        }
        r
    }

    /// True when the tags are 1..N, in that order, already.
    fn identity(&self) -> bool {
        self.order
            .iter()
            .enumerate()
            .all(|(i, &t)| t == i as u64 + 1)
    }

    #[inline]
    fn get(&self, tag: u64) -> Option<u64> {
        if self.dense.is_empty() {
            self.sparse.get(&tag).copied()
        } else {
            match self.dense.get(tag as usize) {
                Some(&n) if n != 0 => Some(n),
                _ => None,
            }
        }
    }

    /// `(old, new)` for every tag up to `limit`, ascending by old tag.
    fn map_up_to(&self, limit: u64) -> Vec<(u64, u64)> {
        self.sorted
            .iter()
            .take_while(|&&t| t <= limit)
            .filter_map(|&t| self.get(t).map(|n| (t, n)))
            .collect()
    }
}

/// The nodes elements of a physical group's entity use (of any entity, when the mesh has no
/// physical group): `used[t]` for tag t, or the set of them when the tags are sparse.
enum Used {
    Dense(Vec<bool>),
    Sparse(HashSet<u64>),
}

impl Used {
    fn of(mesh: &Mesh) -> Used {
        let physical: HashSet<(i32, i32)> = mesh
            .entities
            .iter()
            .flatten()
            .filter(|e| !e.physical_tags.is_empty())
            .map(|e| (e.dim, e.tag))
            .collect();
        // without physical groups, every element counts
        let all = physical.is_empty();
        let blocks = || {
            mesh.element_blocks
                .iter()
                .filter(move |b| all || physical.contains(&(b.entity_dim, b.entity_tag)))
        };
        let max = mesh.max_node_tag();
        if max <= (4 * mesh.node_count() as u64).max(1024) {
            let mut used = vec![false; max as usize + 1];
            for b in blocks() {
                for &n in &b.nodes {
                    if let Some(u) = used.get_mut(n as usize) {
                        *u = true;
                    }
                }
            }
            Used::Dense(used)
        } else {
            Used::Sparse(blocks().flat_map(|b| b.nodes.iter().copied()).collect())
        }
    }

    fn contains(&self, tag: u64) -> bool {
        match self {
            Used::Dense(v) => v.get(tag as usize).copied().unwrap_or(false),
            Used::Sparse(s) => s.contains(&tag),
        }
    }
}

/// Numbers the nodes 1..N and the elements 1..M in the order of their tags (with the
/// exception the module documentation gives), and everything naming them alike. `input`:
/// the input's largest tags, when the [`TagMap`] is wanted. Node tags are kept when an
/// element names a node that is not in the mesh (there is nothing to renumber it to); a
/// data section that cannot be read is dropped. Both are said in
/// [`RenumberReport::warnings`].
pub fn renumber(mesh: &mut Mesh, input: Option<InputTags>) -> RenumberReport {
    let mut report = RenumberReport::default();
    let mut map = TagMap::default();

    // nodes
    let node_tags: Vec<u64> = mesh
        .node_blocks
        .iter()
        .flat_map(|b| b.tags.iter().copied())
        .collect();
    // nodes no physical group's element uses go last, as in Gmsh's own numbering (DOLFINx
    // reads only those elements and fails on an unused node before a used one)
    let used = Used::of(mesh);
    let nodes = Ranks::new(node_tags, |t| !used.contains(t));
    drop(used);
    let dangling = mesh.element_blocks.par_iter().find_map_any(|b| {
        b.tags
            .iter()
            .zip(b.nodes.chunks(b.nodes_per_element().max(1)))
            .find_map(|(&e, ns)| {
                ns.iter()
                    .find(|&&n| nodes.get(n).is_none())
                    .map(|&n| (e, n))
            })
    });
    if let Some((element, node)) = dangling {
        report.warnings.push(format!(
            "node tags kept as they are (not numbered 1..N): element {element} names node {node}, which is not in the mesh"
        ));
    } else {
        if let Some(limits) = input {
            map.nodes = nodes.map_up_to(limits.max_node);
        }
        if !nodes.identity() {
            report.nodes_changed = renumber_nodes(mesh, &nodes, &mut report.warnings);
        }
    }
    drop(nodes);

    // elements
    let element_tags: Vec<u64> = mesh
        .element_blocks
        .iter()
        .flat_map(|b| b.tags.iter().copied())
        .collect();
    let count = element_tags.len();
    let elements = Ranks::new(element_tags, |_| false);
    if elements.sorted.len() < count {
        // a tag used by more than one element (the reader keeps them, with a warning):
        // every element gets a number of its own
        drop(elements);
        report.elements_changed = renumber_repeated_elements(
            mesh,
            input.map(|l| l.max_element),
            &mut map,
            &mut report.warnings,
        );
    } else {
        if let Some(limits) = input {
            map.elements = elements.map_up_to(limits.max_element);
        }
        if !elements.identity() {
            report.elements_changed = renumber_elements(mesh, &elements, &mut report.warnings);
        }
    }
    if input.is_some() {
        report.map = Some(map);
    }
    report
}

/// Maps `tag` in place; returns whether it changed. Tags not in `ranks` stay.
#[inline]
fn remap(tag: &mut u64, ranks: &Ranks) -> bool {
    match ranks.get(*tag) {
        Some(n) if n != *tag => {
            *tag = n;
            true
        }
        _ => false,
    }
}

/// Maps every tag of `tags` in place; returns how many changed.
fn remap_all(tags: &mut [u64], ranks: &Ranks) -> usize {
    tags.iter_mut().map(|t| usize::from(remap(t, ranks))).sum()
}

fn renumber_nodes(mesh: &mut Mesh, ranks: &Ranks, warnings: &mut Vec<String>) -> usize {
    let changed = mesh
        .node_blocks
        .par_iter_mut()
        .map(|b| remap_all(&mut b.tags, ranks))
        .sum();
    mesh.element_blocks.par_iter_mut().for_each(|b| {
        b.nodes.par_iter_mut().for_each(|t| {
            remap(t, ranks);
        })
    });
    for link in &mut mesh.periodic {
        // a pair naming a node not in the mesh names nothing: it goes
        link.node_pairs
            .retain_mut(|(a, b)| match (ranks.get(*a), ranks.get(*b)) {
                (Some(x), Some(y)) => {
                    (*a, *b) = (x, y);
                    true
                }
                _ => false,
            });
    }
    renumber_data(mesh, ranks, DataKind::Node, warnings);
    changed
}

fn renumber_elements(mesh: &mut Mesh, ranks: &Ranks, warnings: &mut Vec<String>) -> usize {
    let changed = mesh
        .element_blocks
        .par_iter_mut()
        .map(|b| remap_all(&mut b.tags, ranks))
        .sum();
    renumber_data(mesh, ranks, DataKind::Element, warnings);
    renumber_data(mesh, ranks, DataKind::ElementNode, warnings);
    changed
}

/// Numbers the elements 1..N in the order of (tag, block, place in block) when some tags
/// repeat, so that every element has a tag of its own; `map` gets `(input tag, new tag)` of
/// each element whose tag is at most `max_input` (a repeated tag once per element). The
/// element data sections go, with a warning: their values cannot be told apart. Returns how
/// many tags changed.
fn renumber_repeated_elements(
    mesh: &mut Mesh,
    max_input: Option<u64>,
    map: &mut TagMap,
    warnings: &mut Vec<String>,
) -> usize {
    let mut order: Vec<(u64, u32, u32)> = mesh
        .element_blocks
        .iter()
        .enumerate()
        .flat_map(|(b, block)| {
            block
                .tags
                .iter()
                .enumerate()
                .map(move |(i, &t)| (t, b as u32, i as u32))
        })
        .collect();
    order.par_sort_unstable();
    let mut changed = 0;
    for (i, &(tag, b, e)) in order.iter().enumerate() {
        let new = i as u64 + 1;
        if max_input.is_some_and(|m| tag <= m) {
            map.elements.push((tag, new));
        }
        if new != tag {
            changed += 1;
        }
        mesh.element_blocks[b as usize].tags[e as usize] = new;
    }
    let before = mesh.data_sections.len();
    mesh.data_sections
        .retain(|d| !matches!(d.kind, DataKind::Element | DataKind::ElementNode));
    let dropped = before - mesh.data_sections.len();
    if dropped > 0 {
        warnings.push(format!(
            "{dropped} element data section(s) dropped: element tags repeat in the input, so their values cannot be told apart"
        ));
    }
    changed
}

/// Renumbers the entity tags of the data sections of `kind`; drops, with a warning, those
/// that cannot be read or name a tag not in use.
fn renumber_data(mesh: &mut Mesh, ranks: &Ranks, kind: DataKind, warnings: &mut Vec<String>) {
    let binary_default = mesh.format.is_some_and(|f| f.binary);
    let mut dropped = 0;
    mesh.data_sections.retain_mut(|d| {
        if d.kind != kind {
            return true;
        }
        let binary = d.encoded_binary.unwrap_or(binary_default);
        match renumber_body(&d.body, binary, kind, ranks) {
            Some(body) => {
                d.body = body;
                true
            }
            None => {
                dropped += 1;
                false
            }
        }
    });
    if dropped > 0 {
        warnings.push(format!(
            "dropped {dropped} ${} section(s): they could not be renumbered with the mesh (unreadable, or naming a tag not in the mesh)",
            kind.section_name()
        ));
    }
}

/// The body of a data section with its entity tags renumbered, or `None` when it cannot be
/// read. Layout (MSH 2.2 and 4.1): the string, real and integer tags, each a count line
/// then one line per tag (the integer tags: time step, components, entries, ...), then one
/// entry per line `tag [nodes] value...` in ASCII, or in binary a 4-byte tag, for
/// `$ElementNodeData` a 4-byte node count, then 8-byte values.
fn renumber_body(body: &[u8], binary: bool, kind: DataKind, ranks: &Ranks) -> Option<Vec<u8>> {
    let mut p = 0;
    let mut ints = Vec::new();
    for group in 0..3 {
        let n: usize = std::str::from_utf8(next_line(body, &mut p)?)
            .ok()?
            .parse()
            .ok()?;
        for _ in 0..n {
            let l = next_line(body, &mut p)?;
            if group == 2 {
                ints.push(std::str::from_utf8(l).ok()?.parse::<i64>().ok()?);
            }
        }
    }
    let components = usize::try_from(*ints.get(1)?).ok()?;
    let entries = usize::try_from(*ints.get(2)?).ok()?;
    let mut out = body[..p].to_vec();
    if binary {
        let mut rest = &body[p..];
        for _ in 0..entries {
            let tag = u64::try_from(i32::from_le_bytes(rest.get(..4)?.try_into().ok()?)).ok()?;
            let new = i32::try_from(ranks.get(tag)?).ok()?;
            out.extend_from_slice(&new.to_le_bytes());
            let mut len = 4;
            let mut values = components;
            if kind == DataKind::ElementNode {
                let k =
                    usize::try_from(i32::from_le_bytes(rest.get(4..8)?.try_into().ok()?)).ok()?;
                values = k.checked_mul(components)?;
                len = 8;
            }
            let end = len + values.checked_mul(8)?;
            out.extend_from_slice(rest.get(4..end)?);
            rest = &rest[end..];
        }
        out.extend_from_slice(rest);
    } else {
        for _ in 0..entries {
            let l = next_line(body, &mut p)?;
            let text = std::str::from_utf8(l).ok()?;
            let (first, tail) = text.split_once(char::is_whitespace).unwrap_or((text, ""));
            let new = ranks.get(first.parse().ok()?)?;
            out.extend_from_slice(new.to_string().as_bytes());
            if !tail.is_empty() {
                out.push(b' ');
                out.extend_from_slice(tail.as_bytes());
            }
            out.push(b'\n');
        }
        out.extend_from_slice(&body[p..]);
    }
    Some(out)
}

/// The line of `body` at `*p` (trimmed), moving `*p` past it.
fn next_line<'a>(body: &'a [u8], p: &mut usize) -> Option<&'a [u8]> {
    let rest = body.get(*p..)?;
    let end = memchr::memchr(b'\n', rest)?;
    *p += end + 1;
    Some(rest[..end].trim_ascii())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::testing::{node_block, one_surface};
    use crate::mesh::{etype, DataSection, ElementBlock, PeriodicLink};

    /// Nodes 2, 5, 9, 40 (gaps, unordered blocks) and two quads 7 and 3, a line 11.
    fn gappy() -> Mesh {
        let mut m = one_surface(
            vec![
                node_block(1, vec![9, 2], vec![[0.0; 3], [1.0, 0.0, 0.0]]),
                node_block(2, vec![40, 5], vec![[1.0, 1.0, 0.0], [0.0, 1.0, 0.0]]),
            ],
            etype::QUAD4,
            &[&[9, 2, 40, 5], &[2, 40, 5, 9]],
        );
        m.element_blocks[0].tags = vec![7, 3];
        m.element_blocks.push(ElementBlock {
            entity_dim: 1,
            entity_tag: 1,
            element_type: etype::LINE2,
            tags: vec![11],
            nodes: vec![9, 2],
            partitions: None,
        });
        m.periodic.push(PeriodicLink {
            dim: 1,
            tag: 2,
            master_tag: 1,
            affine: None,
            node_pairs: vec![(40, 9), (5, 2), (77, 2)],
        });
        m
    }

    #[test]
    fn gaps_close_in_tag_order_and_everything_follows() {
        let mut m = gappy();
        let r = renumber(
            &mut m,
            Some(InputTags {
                max_node: 9,
                max_element: 7,
            }),
        );
        assert_eq!(m.node_blocks[0].tags, vec![3, 1]);
        assert_eq!(m.node_blocks[1].tags, vec![4, 2]);
        assert_eq!(m.element_blocks[0].nodes, vec![3, 1, 4, 2, 1, 4, 2, 3]);
        assert_eq!(m.element_blocks[0].tags, vec![2, 1]);
        assert_eq!(m.element_blocks[1].tags, vec![3]);
        assert_eq!(m.element_blocks[1].nodes, vec![3, 1]);
        // the pair naming node 77, not in the mesh, goes
        assert_eq!(m.periodic[0].node_pairs, vec![(4, 3), (2, 1)]);
        assert_eq!((r.nodes_changed, r.elements_changed), (4, 3));
        let map = r.map.expect("asked for");
        // nodes above 9 and elements above 7 are new: not in the map
        assert_eq!(map.nodes, vec![(2, 1), (5, 2), (9, 3)]);
        assert_eq!(map.elements, vec![(3, 1), (7, 2)]);
        assert!(r.warnings.is_empty());
    }

    #[test]
    fn a_mesh_numbered_without_gaps_is_left_as_it_is() {
        let mut m = gappy();
        renumber(&mut m, None);
        let before = m.clone();
        let r = renumber(&mut m, None);
        assert_eq!(m, before);
        assert_eq!((r.nodes_changed, r.elements_changed), (0, 0));
        assert!(r.map.is_none());
    }

    #[test]
    fn sparse_tags_take_the_sorted_lookup_and_agree_with_the_dense_one() {
        let mut dense = gappy();
        let mut sparse = gappy();
        for t in sparse.node_blocks[1].tags.iter_mut() {
            if *t == 40 {
                *t = 1 << 40;
            }
        }
        for t in sparse.element_blocks[0].nodes.iter_mut() {
            if *t == 40 {
                *t = 1 << 40;
            }
        }
        sparse.periodic[0].node_pairs[0].0 = 1 << 40;
        renumber(&mut dense, None);
        renumber(&mut sparse, None);
        assert_eq!(dense, sparse);
    }

    #[test]
    fn an_element_naming_a_missing_node_keeps_the_node_tags() {
        let mut m = gappy();
        m.element_blocks[1].nodes = vec![9, 1000];
        let r = renumber(&mut m, None);
        assert_eq!(m.node_blocks[0].tags, vec![9, 2]);
        assert_eq!(r.warnings.len(), 1, "{:?}", r.warnings);
        assert!(r.warnings[0].contains("node 1000"), "{}", r.warnings[0]);
        // elements are still numbered
        assert_eq!(m.element_blocks[0].tags, vec![2, 1]);
    }

    fn section(kind: DataKind, header: &str, rows: &[u8], binary: bool) -> DataSection {
        let mut body = header.as_bytes().to_vec();
        body.extend_from_slice(rows);
        DataSection {
            kind,
            body,
            encoded_binary: Some(binary),
        }
    }

    #[test]
    fn data_sections_follow_ascii_and_binary() {
        let mut m = gappy();
        let head = "1\n\"v\"\n1\n0\n3\n0\n1\n2\n";
        m.data_sections
            .push(section(DataKind::Node, head, b"40 0.5\n9 1.5\n", false));
        let mut bin = Vec::new();
        for (t, v) in [(7i32, 2.5f64), (3, -1.0)] {
            bin.extend_from_slice(&t.to_le_bytes());
            bin.extend_from_slice(&v.to_le_bytes());
        }
        bin.push(b'\n');
        m.data_sections
            .push(section(DataKind::Element, head, &bin, true));
        let mut en = Vec::new();
        en.extend_from_slice(&11i32.to_le_bytes());
        en.extend_from_slice(&2i32.to_le_bytes());
        for v in [1.0f64, 2.0] {
            en.extend_from_slice(&v.to_le_bytes());
        }
        en.push(b'\n');
        m.data_sections.push(section(
            DataKind::ElementNode,
            "1\n\"w\"\n1\n0\n3\n0\n1\n1\n",
            &en,
            true,
        ));
        let r = renumber(&mut m, None);
        assert!(r.warnings.is_empty(), "{:?}", r.warnings);
        assert_eq!(
            String::from_utf8_lossy(&m.data_sections[0].body),
            format!("{head}4 0.5\n3 1.5\n")
        );
        let b = &m.data_sections[1].body[head.len()..];
        assert_eq!(b[..4], 2i32.to_le_bytes());
        assert_eq!(b[4..12], 2.5f64.to_le_bytes());
        assert_eq!(b[12..16], 1i32.to_le_bytes());
        assert_eq!(b.len(), 25);
        let e = &m.data_sections[2].body;
        let at = e.len() - 25;
        assert_eq!(e[at..at + 4], 3i32.to_le_bytes());
        assert_eq!(e[at + 4..at + 8], 2i32.to_le_bytes());
    }

    #[test]
    fn a_data_section_that_cannot_follow_is_dropped_with_a_warning() {
        let mut m = gappy();
        let head = "1\n\"v\"\n1\n0\n3\n0\n1\n2\n";
        // names node 41, not in the mesh
        m.data_sections
            .push(section(DataKind::Node, head, b"41 0.5\n9 1.5\n", false));
        // two entries announced, one given
        m.data_sections
            .push(section(DataKind::Node, head, b"9 1.5\n", false));
        let r = renumber(&mut m, None);
        assert!(m.data_sections.is_empty());
        assert_eq!(r.warnings.len(), 1);
        assert!(
            r.warnings[0].contains("dropped 2 $NodeData"),
            "{}",
            r.warnings[0]
        );
    }

    #[test]
    fn nodes_outside_every_physical_group_go_last_in_tag_order() {
        let mut m = gappy();
        // the quads' surface is in a physical group; the line uses nodes 9 and 2 too, and a
        // point entity outside every group holds node 1
        m.entities[2].push(crate::mesh::Entity {
            dim: 2,
            tag: 1,
            bbox: [0.0; 6],
            physical_tags: vec![5],
            bounding: vec![],
        });
        m.node_blocks
            .insert(0, node_block(0, vec![1], vec![[3.0, 0.0, 0.0]]));
        m.element_blocks[0].nodes = vec![9, 2, 40, 9, 2, 40, 9, 2];
        let r = renumber(&mut m, None);
        // used by the surface: 2, 9, 40 -> 1, 2, 3; then 1 and 5 (no physical element)
        assert_eq!(m.node_blocks[0].tags, vec![4]);
        assert_eq!(m.node_blocks[1].tags, vec![2, 1]);
        assert_eq!(m.node_blocks[2].tags, vec![3, 5]);
        assert_eq!(r.nodes_changed, 4);
        // already so: unchanged
        let before = m.clone();
        renumber(&mut m, None);
        assert_eq!(m, before);
    }

    #[test]
    fn without_physical_groups_nodes_no_element_uses_go_last() {
        let mut m = gappy();
        // node 3 (a dropped volume's, say) is used by no element
        m.node_blocks
            .push(node_block(3, vec![3], vec![[0.5, 0.5, 1.0]]));
        renumber(&mut m, None);
        assert_eq!(m.node_blocks[0].tags, vec![3, 1]);
        assert_eq!(m.node_blocks[1].tags, vec![4, 2]);
        assert_eq!(m.node_blocks[2].tags, vec![5]);
    }
}
