//! MSH 2.x (2.0, 2.1, 2.2): section readers and the lift of the flat node and element lists
//! into the entity-based [`Mesh`] model.
//!
//! The conventions of the lift are documented on the `msh` module ("Reading MSH 2.x").

use std::collections::HashMap;

use super::derive;
use super::error::{ErrorKind, Fail, PResult};
use super::scan::{i32_at, u64_at, Bin, Text};
use super::tags::TagMap;
use super::v4::TICK_LINES;
use crate::mesh::{element_dim, element_node_count, ElementBlock, Entity, Mesh, NodeBlock};

/// One element as read, before the lift.
struct RawElem {
    id: u64,
    etype: u32,
    phys: i32,
    elementary: i32,
    nodes: usize,
    parts: usize,
    nparts: u32,
}

/// Flat MSH 2.x data, collected section by section.
#[derive(Default)]
pub(crate) struct Raw2 {
    node_tags: Vec<u64>,
    coords: Vec<[f64; 3]>,
    /// Per node from `$ParametricNodes`: entity dim, entity tag, index into `params`.
    node_class: Vec<(i32, i32, usize)>,
    params: Vec<f64>,
    elems: Vec<RawElem>,
    elem_nodes: Vec<u64>,
    elem_parts: Vec<i32>,
    /// Byte offset of each element record (for error positions).
    elem_pos: Vec<usize>,
    elem_binary: bool,
    negative_phys: usize,
}

impl Raw2 {
    /// Node tags read so far, in file order.
    pub fn node_tags(&self) -> &[u64] {
        &self.node_tags
    }
}

/// `$Nodes` (ASCII): `n`, then `id x y z` per line.
/// `tick(offset)` is called every [`TICK_LINES`] lines (progress).
pub(crate) fn nodes_ascii(
    t: &mut Text,
    raw: &mut Raw2,
    tick: &mut dyn FnMut(usize),
) -> PResult<()> {
    let n = t.count("number of nodes", 8)?;
    raw.node_tags.reserve(n);
    raw.coords.reserve(n);
    for _ in 0..n {
        raw.node_tags.push(t.u64("node tag")?);
        let x = t.f64_inline("coordinates", 0, 3)?;
        let y = t.f64_inline("coordinates", 1, 3)?;
        let z = t.f64_inline("coordinates", 2, 3)?;
        raw.coords.push([x, y, z]);
        t.end_line("node line")?;
        if raw.coords.len().is_multiple_of(TICK_LINES) {
            tick(t.p);
        }
    }
    Ok(())
}

/// `$Nodes` (binary): ASCII count line, then per node `int id` and three doubles.
pub(crate) fn nodes_binary(t: &mut Text, swap: bool, raw: &mut Raw2) -> PResult<()> {
    let n = t.count("number of nodes", 8)?;
    // The count line ends with a newline; binary data starts right after it.
    t.next_line();
    let mut b = Bin::new(t.d, t.p, swap);
    let base = b.p;
    let data = b.take(28 * n as u64, "node records (28 bytes each)")?;
    raw.node_tags.reserve(n);
    raw.coords.reserve(n);
    for (i, rec) in data.chunks_exact(28).enumerate() {
        let id = i32_at(rec, swap);
        let id = u64::try_from(id).map_err(|_| {
            Fail::bin(
                base + 28 * i,
                ErrorKind::Invalid(format!("negative node tag {id}")),
            )
        })?;
        let mut c = [0.0; 3];
        for (k, v) in c.iter_mut().enumerate() {
            *v = f64::from_bits(u64_at(&rec[4 + 8 * k..], swap));
            if !v.is_finite() {
                return Err(Fail::bin(
                    base + 28 * i + 4 + 8 * k,
                    ErrorKind::NotFinite {
                        what: "coordinate".into(),
                        found: v.to_string(),
                    },
                ));
            }
        }
        raw.node_tags.push(id);
        raw.coords.push(c);
    }
    t.p = b.p;
    Ok(())
}

/// `$ParametricNodes` (ASCII): `n`, then `id x y z dim tag [u [v]]` per line.
pub(crate) fn parametric_nodes_ascii(t: &mut Text, raw: &mut Raw2) -> PResult<()> {
    let n = t.count("number of nodes", 8)?;
    for _ in 0..n {
        raw.node_tags.push(t.u64("node tag")?);
        let x = t.f64_inline("fields", 0, 5)?;
        let y = t.f64_inline("fields", 1, 5)?;
        let z = t.f64_inline("fields", 2, 5)?;
        raw.coords.push([x, y, z]);
        t.skip_inline_ws();
        let dpos = t.at();
        let dim = t.i32_inline("fields", 3, 5)?;
        if !(0..=3).contains(&dim) {
            return Err(Fail::at(
                dpos,
                ErrorKind::Invalid(format!("entity dimension {dim} is not in 0..=3")),
            ));
        }
        let tag = t.i32_inline("fields", 4, 5)?;
        let np = if dim == 1 || dim == 2 {
            dim as usize
        } else {
            0
        };
        let start = raw.params.len();
        for k in 0..np {
            raw.params.push(t.f64_inline("fields", 5 + k, 5 + np)?);
        }
        raw.node_class.resize(raw.node_tags.len() - 1, (-1, 0, 0));
        raw.node_class.push((dim, tag, start));
        t.end_line("parametric node line")?;
    }
    Ok(())
}

fn elem_type(pos: usize, binary: bool, ty: i32) -> PResult<(u32, usize)> {
    u32::try_from(ty)
        .ok()
        .and_then(|t| element_node_count(t).map(|k| (t, k)))
        .ok_or_else(|| Fail::new(pos, binary, ErrorKind::UnknownElementType(ty as i64)))
}

impl Raw2 {
    fn push_elem(&mut self, id: u64, etype: u32, tags: &[i32], pos: usize) {
        let mut phys = tags.first().copied().unwrap_or(0);
        if phys < 0 {
            self.negative_phys += 1;
            phys = phys.saturating_abs();
        }
        let elementary = tags.get(1).copied().unwrap_or(0);
        let extra = tags.get(2..).unwrap_or(&[]);
        self.elems.push(RawElem {
            id,
            etype,
            phys,
            elementary,
            nodes: self.elem_nodes.len(),
            parts: self.elem_parts.len(),
            nparts: extra.len() as u32,
        });
        self.elem_parts.extend_from_slice(extra);
        self.elem_pos.push(pos);
    }
}

/// Largest number of tags per element accepted (Gmsh writes at most a few partitions).
const MAX_TAGS: usize = 1024;

/// `$Elements` (ASCII): `n`, then one line per element `id type ntags tag… node…`. A line
/// with more fields than `ntags` + the type's node count is refused.
/// `tick(offset)` is called every [`TICK_LINES`] lines (progress).
pub(crate) fn elements_ascii(
    t: &mut Text,
    raw: &mut Raw2,
    tick: &mut dyn FnMut(usize),
) -> PResult<()> {
    let n = t.count("number of elements", 8)?;
    raw.elems.reserve(n);
    let mut tags = Vec::new();
    let mut nodes = Vec::new();
    for i in 0..n {
        if i.is_multiple_of(TICK_LINES) {
            tick(t.p);
        }
        t.skip_ws();
        let pos = t.at();
        let id = t.u64("element id")?;
        t.skip_inline_ws();
        let tpos = t.at();
        let ty = t.i32_inline("element fields", 1, 3)?;
        let (etype, k) = elem_type(tpos, false, ty)?;
        t.skip_inline_ws();
        let npos = t.at();
        let ntags = t.u64_inline("element fields", 2, 3)? as usize;
        if ntags > MAX_TAGS {
            return Err(Fail::at(
                npos,
                ErrorKind::Invalid(format!("element {id} declares {ntags} tags")),
            ));
        }
        tags.clear();
        for j in 0..ntags {
            tags.push(t.i32_inline("tags and nodes", j, ntags + k)?);
        }
        nodes.clear();
        for j in 0..k {
            nodes.push(t.u64_inline("tags and nodes", ntags + j, ntags + k)?);
        }
        raw.push_elem(id, etype, &tags, pos);
        raw.elem_nodes.extend_from_slice(&nodes);
        t.end_line("element line").map_err(|mut f| {
            if let ErrorKind::TooManyFields { what, .. } = &mut f.kind {
                *what = format!("element {id} (type {etype}: {ntags} tags + {k} nodes)");
            }
            f
        })?;
    }
    Ok(())
}

/// `$Elements` (binary): ASCII count line, then blocks: header `int type, int count, int
/// ntags`, and per element `int id`, `ntags` ints, the node ints.
pub(crate) fn elements_binary(t: &mut Text, swap: bool, raw: &mut Raw2) -> PResult<()> {
    let n = t.count("number of elements", 8)?;
    t.next_line();
    let mut b = Bin::new(t.d, t.p, swap);
    raw.elem_binary = true;
    raw.elems.reserve(n);
    let mut done = 0usize;
    let mut tags = Vec::new();
    while done < n {
        let hpos = b.p;
        let ty = b.i32("element block header")?;
        let (etype, k) = elem_type(hpos, true, ty)?;
        let cpos = b.p;
        let count = b.i32("element block count")?;
        let ntags = b.i32("element block tag count")?;
        if count < 0 || ntags < 0 || ntags as usize > MAX_TAGS {
            return Err(Fail::bin(
                cpos,
                ErrorKind::Invalid(format!(
                    "bad element block header: count {count}, {ntags} tags"
                )),
            ));
        }
        let (count, ntags) = (count as usize, ntags as usize);
        if count > n - done {
            return Err(Fail::bin(
                cpos,
                ErrorKind::CountMismatch {
                    what: "elements in binary blocks".into(),
                    declared: n as u64,
                    found: (done + count) as u64,
                },
            ));
        }
        let w = 4 * (1 + ntags + k);
        let base = b.p;
        let data = b.take((w * count) as u64, "element records")?;
        for (i, rec) in data.chunks_exact(w).enumerate() {
            let pos = base + i * w;
            let id = i32_at(rec, swap);
            let id = u64::try_from(id).map_err(|_| {
                Fail::bin(pos, ErrorKind::Invalid(format!("negative element id {id}")))
            })?;
            tags.clear();
            tags.extend(
                rec[4..4 + 4 * ntags]
                    .chunks_exact(4)
                    .map(|c| i32_at(c, swap)),
            );
            raw.push_elem(id, etype, &tags, pos);
            for (j, c) in rec[4 + 4 * ntags..].chunks_exact(4).enumerate() {
                let v = i32_at(c, swap);
                let v = u64::try_from(v).map_err(|_| {
                    Fail::bin(
                        pos + 4 * (1 + ntags + j),
                        ErrorKind::Invalid(format!("negative node tag {v}")),
                    )
                })?;
                raw.elem_nodes.push(v);
            }
        }
        done += count;
    }
    t.p = b.p;
    Ok(())
}

/// Identity of an element for merging per-group copies: entity dim, elementary tag, type,
/// nodes, partition tags.
type CopyKey<'a> = (i32, i32, u32, &'a [u64], &'a [i32]);

/// Builds the entity-based model from the flat 2.x data (see the module documentation).
pub(crate) fn lift(raw: Raw2, mesh: &mut Mesh) -> PResult<()> {
    let nodes_of = |e: &RawElem| {
        let k = element_node_count(e.etype).unwrap_or(0);
        &raw.elem_nodes[e.nodes..e.nodes + k]
    };
    let parts_of = |e: &RawElem| &raw.elem_parts[e.parts..e.parts + e.nparts as usize];

    // Every referenced node must exist.
    let node_map = TagMap::new(&raw.node_tags);
    for (i, e) in raw.elems.iter().enumerate() {
        for &v in nodes_of(e) {
            if node_map.get(v).is_none() {
                let pos = raw.elem_pos[i];
                let kind = ErrorKind::MissingNode {
                    element: e.id,
                    node: v,
                };
                // Position: the element's line (ASCII) or record start (binary).
                return Err(Fail::new(pos, raw.elem_binary, kind));
            }
        }
    }
    if raw.negative_phys > 0 {
        mesh.warnings.push(format!(
            "{} element(s) carry a negative physical tag (old Gmsh 'reversed' flag): read as the positive tag, nodes kept as written",
            raw.negative_phys
        ));
    }

    // Which elementary entities carry more than one physical tag (only those can hold
    // per-group copies).
    let mut ent_phys: HashMap<(i32, i32), (i32, bool)> = HashMap::new();
    let mut last = None;
    for e in &raw.elems {
        let dim = element_dim(e.etype).unwrap_or(0);
        // Consecutive elements mostly share entity and group: skip the hash then.
        if last == Some((dim, e.elementary, e.phys)) {
            continue;
        }
        last = Some((dim, e.elementary, e.phys));
        let s = ent_phys
            .entry((dim, e.elementary))
            .or_insert((e.phys, false));
        if s.0 != e.phys {
            s.1 = true;
        }
    }

    // Merge per-group copies. `kept` lists raw indices; `extra` the merged physical tags.
    let mut kept: Vec<usize> = Vec::with_capacity(raw.elems.len());
    let mut extra: HashMap<usize, Vec<i32>> = HashMap::new();
    let mut seen: HashMap<CopyKey, Vec<usize>> = HashMap::new();
    let mut merged = 0usize;
    let mut last_multi: Option<((i32, i32), bool)> = None;
    for (i, e) in raw.elems.iter().enumerate() {
        let dim = element_dim(e.etype).unwrap_or(0);
        let multi = match last_multi {
            Some((key, m)) if key == (dim, e.elementary) => m,
            _ => {
                let m = ent_phys.get(&(dim, e.elementary)).is_some_and(|s| s.1);
                last_multi = Some(((dim, e.elementary), m));
                m
            }
        };
        if !multi {
            kept.push(i);
            continue;
        }
        let key = (dim, e.elementary, e.etype, nodes_of(e), parts_of(e));
        let cands = seen.entry(key).or_default();
        let mut target = None;
        for &k in cands.iter() {
            let base = raw.elems[kept[k]].phys;
            let has = base == e.phys || extra.get(&k).is_some_and(|v| v.contains(&e.phys));
            if !has {
                target = Some(k);
                break;
            }
        }
        match target {
            Some(k) => {
                extra.entry(k).or_default().push(e.phys);
                merged += 1;
            }
            None => {
                cands.push(kept.len());
                kept.push(i);
            }
        }
    }
    drop(seen);
    if merged > 0 {
        mesh.warnings.push(format!(
            "merged {merged} element line(s) that repeat an element once per physical group (Gmsh MSH 2 convention); they are written back the same way"
        ));
    }

    // Physical set of each kept element → entity (split when sets differ).
    let mut max_tag = [0i32; 4];
    for e in &raw.elems {
        let d = element_dim(e.etype).unwrap_or(0) as usize;
        max_tag[d] = max_tag[d].max(e.elementary);
    }
    for &(d, t, _) in &raw.node_class {
        if (0..4).contains(&d) {
            max_tag[d as usize] = max_tag[d as usize].max(t);
        }
    }
    // entity list: (dim, tag, physical set)
    let mut ents: Vec<(i32, i32, Vec<i32>)> = Vec::new();
    let mut ent_of: HashMap<(i32, i32), Vec<usize>> = HashMap::new();
    let mut elem_ent: Vec<u32> = Vec::with_capacity(kept.len());
    let mut set = Vec::new();
    let mut splits = 0usize;
    let mut last_ent: Option<(i32, i32, u32)> = None;
    for (k, &i) in kept.iter().enumerate() {
        let e = &raw.elems[i];
        let dim = element_dim(e.etype).unwrap_or(0);
        set.clear();
        if e.phys != 0 {
            set.push(e.phys);
        }
        if let Some(x) = (!extra.is_empty()).then(|| extra.get(&k)).flatten() {
            for &p in x {
                if p != 0 && !set.contains(&p) {
                    set.push(p);
                }
            }
        }
        if let Some((d, el, idx)) = last_ent {
            if d == dim && el == e.elementary && ents[idx as usize].2 == set {
                elem_ent.push(idx);
                continue;
            }
        }
        let cands = ent_of.entry((dim, e.elementary)).or_default();
        let found = cands.iter().copied().find(|&c| ents[c].2 == set);
        let idx = match found {
            Some(c) => c,
            None => {
                let tag = if cands.is_empty() {
                    e.elementary
                } else {
                    splits += 1;
                    max_tag[dim as usize] = max_tag[dim as usize].saturating_add(1);
                    max_tag[dim as usize]
                };
                ents.push((dim, tag, set.clone()));
                cands.push(ents.len() - 1);
                ents.len() - 1
            }
        };
        elem_ent.push(idx as u32);
        last_ent = Some((dim, e.elementary, idx as u32));
    }
    if splits > 0 {
        mesh.warnings.push(format!(
            "{splits} elementary entit(y/ies) hold elements with different physical groups: split into new entities so every element keeps its groups"
        ));
    }
    // Entities from $ParametricNodes that hold no element.
    for &(d, t, _) in &raw.node_class {
        if d >= 0 && !ent_of.contains_key(&(d, t)) {
            ents.push((d, t, Vec::new()));
            ent_of.insert((d, t), vec![ents.len() - 1]);
        }
    }

    // Element blocks per (entity, type), sorted by (dim, tag, type).
    let with_parts = raw.elems.iter().any(|e| e.nparts > 0);
    let mut block_of: HashMap<(u32, u32), usize> = HashMap::new();
    let mut blocks: Vec<ElementBlock> = Vec::new();
    let mut last_block: Option<(u32, u32, usize)> = None;
    for (k, &i) in kept.iter().enumerate() {
        let e = &raw.elems[i];
        let ei = elem_ent[k];
        let b = match last_block {
            Some((lei, lty, lb)) if lei == ei && lty == e.etype => lb,
            _ => *block_of.entry((ei, e.etype)).or_insert_with(|| {
                let (d, t, _) = &ents[ei as usize];
                blocks.push(ElementBlock {
                    entity_dim: *d,
                    entity_tag: *t,
                    element_type: e.etype,
                    tags: Vec::new(),
                    nodes: Vec::new(),
                    partitions: with_parts.then(Vec::new),
                });
                blocks.len() - 1
            }),
        };
        last_block = Some((ei, e.etype, b));
        let blk = &mut blocks[b];
        blk.tags.push(e.id);
        blk.nodes.extend_from_slice(nodes_of(e));
        if let Some(p) = blk.partitions.as_mut() {
            p.push(parts_of(e).to_vec());
        }
    }
    blocks.sort_by_key(|b| (b.entity_dim, b.entity_tag, b.element_type));

    // Node classification.
    let mut ent_index: HashMap<(i32, i32), usize> = HashMap::new();
    for (i, (d, t, _)) in ents.iter().enumerate() {
        ent_index.entry((*d, *t)).or_insert(i);
    }
    let nn = raw.node_tags.len();
    let mut class = vec![u32::MAX; nn];
    let parametric = !raw.node_class.is_empty();
    if parametric {
        for (i, &(d, t, _)) in raw.node_class.iter().enumerate() {
            if d >= 0 {
                if let Some(&e) = ent_index.get(&(d, t)) {
                    class[i] = e as u32;
                }
            }
        }
    }
    // Bounding boxes are grown here, where the node positions are at hand.
    let mut ebox = vec![derive::EMPTY_BOX; ents.len()];
    for b in &blocks {
        let e = ent_index
            .get(&(b.entity_dim, b.entity_tag))
            .copied()
            .unwrap_or(0);
        for &v in &b.nodes {
            if let Some(i) = node_map.get(v) {
                if class[i] == u32::MAX {
                    class[i] = e as u32;
                } else if class[i] != e as u32 {
                    // Nodes classified on this entity are added to its box below, in one
                    // sequential pass; only the others need the (cache-missing) lookup.
                    derive::grow_box(&mut ebox[e], &raw.coords[i]);
                }
            }
        }
    }
    let mut unused = 0usize;
    for c in class.iter_mut() {
        if *c == u32::MAX {
            max_tag[0] = max_tag[0].saturating_add(1);
            ents.push((0, max_tag[0], Vec::new()));
            *c = (ents.len() - 1) as u32;
            unused += 1;
        }
    }
    if unused > 0 {
        mesh.warnings.push(format!(
            "{unused} node(s) used by no element: each put on a new point entity"
        ));
    }
    ebox.resize(ents.len(), derive::EMPTY_BOX);
    for (c, x) in class.iter().zip(&raw.coords) {
        derive::grow_box(&mut ebox[*c as usize], x);
    }
    // Node blocks in entity order (dim, tag), nodes in file order.
    let mut order: Vec<usize> = (0..ents.len()).collect();
    order.sort_by_key(|&i| (ents[i].0, ents[i].1));
    let mut rank = vec![0usize; ents.len()];
    for (r, &i) in order.iter().enumerate() {
        rank[i] = r;
    }
    let mut nblocks: Vec<NodeBlock> = order
        .iter()
        .map(|&i| NodeBlock {
            entity_dim: ents[i].0,
            entity_tag: ents[i].1,
            tags: Vec::new(),
            coords: Vec::new(),
            params: None,
        })
        .collect();
    for i in 0..nn {
        let b = &mut nblocks[rank[class[i] as usize]];
        b.tags.push(raw.node_tags[i]);
        b.coords.push(raw.coords[i]);
    }
    if parametric {
        for b in nblocks.iter_mut() {
            if b.entity_dim == 1 || b.entity_dim == 2 {
                b.params = Some(Vec::with_capacity(b.tags.len() * b.entity_dim as usize));
            }
        }
        for i in 0..nn {
            let b = &mut nblocks[rank[class[i] as usize]];
            if let Some(p) = b.params.as_mut() {
                let np = b.entity_dim as usize;
                match raw.node_class.get(i) {
                    Some(&(d, _, start)) if d == b.entity_dim => {
                        p.extend_from_slice(&raw.params[start..start + np]);
                    }
                    _ => p.extend(std::iter::repeat_n(0.0, np)),
                }
            }
        }
    }
    nblocks.retain(|b| !b.tags.is_empty());

    // Entities.
    for &i in &order {
        let (d, t, ref phys) = ents[i];
        mesh.entities[d as usize].push(Entity {
            dim: d,
            tag: t,
            bbox: derive::finish_box(ebox[i]),
            physical_tags: phys.clone(),
            bounding: Vec::new(),
        });
    }
    // Drop duplicate entity entries (same dim and tag from parametric classification).
    for v in mesh.entities.iter_mut() {
        v.dedup_by_key(|e| e.tag);
    }
    mesh.node_blocks = nblocks;
    mesh.element_blocks = blocks;
    mesh.has_entities_section = false;
    derive::bounding_entities(mesh);
    Ok(())
}
