//! Section readers for MSH 4.1 (ASCII and binary) and MSH 4.0 (ASCII).
//!
//! Each function reads the body of one section, from just after its `$Name` line to just
//! before its `$EndName` line, straight into the [`Mesh`].

use super::error::{ErrorKind, Fail, PResult};
use super::scan::{f64s_into, u64_at, Bin, Text};
use crate::mesh::{
    element_node_count, ElementBlock, Entity, Mesh, NodeBlock, NodeIndex, PeriodicLink,
};

/// Number of parametric values per node for a block on an entity of dimension `dim`.
fn param_count(parametric: bool, dim: i32) -> usize {
    if parametric {
        dim.clamp(0, 3) as usize
    } else {
        0
    }
}

fn bad_dim(pos: usize, binary: bool, dim: i32) -> Fail {
    let kind = ErrorKind::Invalid(format!("entity dimension {dim} is not in 0..=3"));
    if binary {
        Fail::bin(pos, kind)
    } else {
        Fail::at(pos, kind)
    }
}

/// `$Entities` (ASCII). 4.1: `numPoints numCurves numSurfaces numVolumes`, a point is
/// `tag x y z numPhys phys…`, other entities `tag minX minY minZ maxX maxY maxZ numPhys
/// phys… numBound bound…`. 4.0 gives points a bounding box too.
pub(crate) fn entities_ascii(t: &mut Text, v40: bool, mesh: &mut Mesh) -> PResult<()> {
    let mut counts = [0usize; 4];
    for c in counts.iter_mut() {
        *c = t.count("entity count")?;
    }
    for (dim, &n) in counts.iter().enumerate() {
        let mut v = Vec::with_capacity(n);
        for _ in 0..n {
            let tag = t.i32("entity tag")?;
            let mut bbox = [0.0; 6];
            if dim == 0 && !v40 {
                for k in 0..3 {
                    bbox[k] = t.f64("point coordinate")?;
                    bbox[k + 3] = bbox[k];
                }
            } else {
                for b in bbox.iter_mut() {
                    *b = t.f64("bounding box value")?;
                }
            }
            let np = t.count("number of physical tags")?;
            let mut physical_tags = Vec::with_capacity(np);
            for _ in 0..np {
                physical_tags.push(t.i32("physical tag")?);
            }
            let mut bounding = Vec::new();
            if dim > 0 {
                let nb = t.count("number of bounding entities")?;
                bounding.reserve(nb);
                for _ in 0..nb {
                    bounding.push(t.i32("bounding entity tag")?);
                }
            }
            v.push(Entity {
                dim: dim as i32,
                tag,
                bbox,
                physical_tags,
                bounding,
            });
        }
        mesh.entities[dim].extend(v);
    }
    mesh.has_entities_section = true;
    Ok(())
}

/// `$Entities` (binary 4.1): the same fields, counts as `size_t`, tags as `int`.
pub(crate) fn entities_binary(b: &mut Bin, mesh: &mut Mesh) -> PResult<()> {
    let mut counts = [0usize; 4];
    for c in counts.iter_mut() {
        *c = b.count("entity count", 4)?;
    }
    for (dim, &n) in counts.iter().enumerate() {
        for _ in 0..n {
            let tag = b.i32("entity tag")?;
            let mut bbox = [0.0; 6];
            if dim == 0 {
                for k in 0..3 {
                    bbox[k] = b.f64("point coordinate")?;
                    bbox[k + 3] = bbox[k];
                }
            } else {
                for v in bbox.iter_mut() {
                    *v = b.f64("bounding box value")?;
                }
            }
            let np = b.count("number of physical tags", 4)?;
            let mut physical_tags = Vec::with_capacity(np);
            for _ in 0..np {
                physical_tags.push(b.i32("physical tag")?);
            }
            let mut bounding = Vec::new();
            if dim > 0 {
                let nb = b.count("number of bounding entities", 4)?;
                for _ in 0..nb {
                    bounding.push(b.i32("bounding entity tag")?);
                }
            }
            mesh.entities[dim].push(Entity {
                dim: dim as i32,
                tag,
                bbox,
                physical_tags,
                bounding,
            });
        }
    }
    mesh.has_entities_section = true;
    Ok(())
}

/// `$Nodes` (ASCII). 4.1: `numBlocks numNodes minTag maxTag`, per block `entityDim entityTag
/// parametric numNodes`, then all node tags, then one coordinate row per node. 4.0: header
/// without min/max, block header `entityTag entityDim ...`, each row `tag x y z [u v]`.
pub(crate) fn nodes_ascii(t: &mut Text, v40: bool, mesh: &mut Mesh) -> PResult<()> {
    let nblocks = t.count("number of node blocks")?;
    t.skip_ws();
    let header_pos = t.at();
    let total = t.u64("number of nodes")?;
    if !v40 {
        t.u64("minimum node tag")?;
        t.u64("maximum node tag")?;
    }
    let mut found = 0u64;
    for _ in 0..nblocks {
        t.skip_ws();
        let bpos = t.at();
        let (entity_dim, entity_tag) = if v40 {
            let tag = t.i32("entity tag")?;
            (t.i32("entity dimension")?, tag)
        } else {
            (t.i32("entity dimension")?, t.i32("entity tag")?)
        };
        if !(0..=3).contains(&entity_dim) {
            return Err(bad_dim(bpos, false, entity_dim));
        }
        let parametric = t.i32("parametric flag")? != 0;
        let n = t.count("number of nodes in block")?;
        let np = param_count(parametric, entity_dim);
        let mut tags = Vec::with_capacity(n);
        let mut coords = Vec::with_capacity(n);
        let mut params = Vec::with_capacity(n * np);
        let width = 3 + np;
        if v40 {
            for _ in 0..n {
                tags.push(t.u64("node tag")?);
                let x = t.f64_inline("coordinates", 0, width)?;
                let y = t.f64_inline("coordinates", 1, width)?;
                let z = t.f64_inline("coordinates", 2, width)?;
                coords.push([x, y, z]);
                for k in 0..np {
                    params.push(t.f64_inline("coordinates", 3 + k, width)?);
                }
                t.end_line("node line")?;
            }
        } else {
            for _ in 0..n {
                tags.push(t.u64("node tag")?);
            }
            for _ in 0..n {
                let x = t.f64("coordinates")?;
                let y = t.f64_inline("coordinates", 1, width)?;
                let z = t.f64_inline("coordinates", 2, width)?;
                coords.push([x, y, z]);
                for k in 0..np {
                    params.push(t.f64_inline("coordinates", 3 + k, width)?);
                }
                t.end_line("coordinate line")?;
            }
        }
        found += n as u64;
        mesh.node_blocks.push(NodeBlock {
            entity_dim,
            entity_tag,
            tags,
            coords,
            params: parametric.then_some(params),
        });
    }
    if found != total {
        return Err(Fail::at(
            header_pos,
            ErrorKind::CountMismatch {
                what: "number of nodes".into(),
                declared: total,
                found,
            },
        ));
    }
    Ok(())
}

/// `$Nodes` (binary 4.1): header of four `size_t`, block headers `int int int size_t`, node
/// tags as `size_t`, coordinates as `double`.
pub(crate) fn nodes_binary(b: &mut Bin, mesh: &mut Mesh) -> PResult<()> {
    let nblocks = b.count("number of node blocks", 20)?;
    let header_pos = b.p;
    let total = b.u64("number of nodes")?;
    b.u64("minimum node tag")?;
    b.u64("maximum node tag")?;
    let mut found = 0u64;
    for _ in 0..nblocks {
        let bpos = b.p;
        let entity_dim = b.i32("entity dimension")?;
        let entity_tag = b.i32("entity tag")?;
        if !(0..=3).contains(&entity_dim) {
            return Err(bad_dim(bpos, true, entity_dim));
        }
        let parametric = b.i32("parametric flag")? != 0;
        let np = param_count(parametric, entity_dim);
        let n = b.count("number of nodes in block", 8 * (4 + np as u64))?;
        let raw = b.take(8 * n as u64, "node tags")?;
        let tags: Vec<u64> = raw.chunks_exact(8).map(|c| u64_at(c, b.swap)).collect();
        let base = b.p;
        let raw = b.take(8 * (3 + np as u64) * n as u64, "node coordinates")?;
        let mut flat = Vec::new();
        f64s_into(raw, base, b.swap, "coordinate", &mut flat)?;
        let (coords, params) = if np == 0 {
            (
                flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
                None,
            )
        } else {
            let w = 3 + np;
            let coords = flat.chunks_exact(w).map(|c| [c[0], c[1], c[2]]).collect();
            let params = flat
                .chunks_exact(w)
                .flat_map(|c| c[3..].iter().copied())
                .collect();
            (coords, Some(params))
        };
        found += n as u64;
        mesh.node_blocks.push(NodeBlock {
            entity_dim,
            entity_tag,
            tags,
            coords,
            params: if parametric {
                params.or(Some(Vec::new()))
            } else {
                None
            },
        });
    }
    if found != total {
        return Err(Fail::bin(
            header_pos,
            ErrorKind::CountMismatch {
                what: "number of nodes".into(),
                declared: total,
                found,
            },
        ));
    }
    Ok(())
}

fn unknown_type(pos: usize, binary: bool, ty: i64) -> Fail {
    let kind = ErrorKind::UnknownElementType(ty);
    if binary {
        Fail::bin(pos, kind)
    } else {
        Fail::at(pos, kind)
    }
}

/// `$Elements` (ASCII). 4.1: `numBlocks numElements minTag maxTag`, per block `entityDim
/// entityTag elementType numElements`, then one line per element: `tag node…`. 4.0: no
/// min/max, block header `entityTag entityDim ...`.
pub(crate) fn elements_ascii(
    t: &mut Text,
    v40: bool,
    mesh: &mut Mesh,
    index: Option<&NodeIndex>,
) -> PResult<()> {
    let nblocks = t.count("number of element blocks")?;
    t.skip_ws();
    let header_pos = t.at();
    let total = t.u64("number of elements")?;
    if !v40 {
        t.u64("minimum element tag")?;
        t.u64("maximum element tag")?;
    }
    let mut found = 0u64;
    for _ in 0..nblocks {
        t.skip_ws();
        let bpos = t.at();
        let (entity_dim, entity_tag) = if v40 {
            let tag = t.i32("entity tag")?;
            (t.i32("entity dimension")?, tag)
        } else {
            (t.i32("entity dimension")?, t.i32("entity tag")?)
        };
        if !(0..=3).contains(&entity_dim) {
            return Err(bad_dim(bpos, false, entity_dim));
        }
        t.skip_ws();
        let tpos = t.at();
        let ty = t.i32("element type")?;
        let k = u32::try_from(ty)
            .ok()
            .and_then(element_node_count)
            .ok_or_else(|| unknown_type(tpos, false, ty as i64))?;
        let n = t.count("number of elements in block")?;
        let mut tags = Vec::with_capacity(n);
        let mut nodes = Vec::with_capacity(n * k);
        for _ in 0..n {
            let etag = t.u64("element tag")?;
            tags.push(etag);
            for j in 0..k {
                t.skip_inline_ws();
                let npos = t.at();
                let node = t.u64_inline("node tags", j, k)?;
                if let Some(ix) = index {
                    if ix.get(node).is_none() {
                        return Err(Fail::at(
                            npos,
                            ErrorKind::MissingNode {
                                element: etag,
                                node,
                            },
                        ));
                    }
                }
                nodes.push(node);
            }
            t.end_line("element line")?;
        }
        found += n as u64;
        mesh.element_blocks.push(ElementBlock {
            entity_dim,
            entity_tag,
            element_type: ty as u32,
            tags,
            nodes,
            partitions: None,
        });
    }
    if found != total {
        return Err(Fail::at(
            header_pos,
            ErrorKind::CountMismatch {
                what: "number of elements".into(),
                declared: total,
                found,
            },
        ));
    }
    Ok(())
}

/// `$Elements` (binary 4.1): header of four `size_t`, block headers `int int int size_t`,
/// then per element `size_t` tag and node tags.
pub(crate) fn elements_binary(
    b: &mut Bin,
    mesh: &mut Mesh,
    index: Option<&NodeIndex>,
) -> PResult<()> {
    let nblocks = b.count("number of element blocks", 20)?;
    let header_pos = b.p;
    let total = b.u64("number of elements")?;
    b.u64("minimum element tag")?;
    b.u64("maximum element tag")?;
    let mut found = 0u64;
    for _ in 0..nblocks {
        let bpos = b.p;
        let entity_dim = b.i32("entity dimension")?;
        let entity_tag = b.i32("entity tag")?;
        if !(0..=3).contains(&entity_dim) {
            return Err(bad_dim(bpos, true, entity_dim));
        }
        let tpos = b.p;
        let ty = b.i32("element type")?;
        let k = u32::try_from(ty)
            .ok()
            .and_then(element_node_count)
            .ok_or_else(|| unknown_type(tpos, true, ty as i64))?;
        let w = 8 * (1 + k as u64);
        let n = b.count("number of elements in block", w)?;
        let base = b.p;
        let raw = b.take(w * n as u64, "element data")?;
        let mut tags = Vec::with_capacity(n);
        let mut nodes = Vec::with_capacity(n * k);
        let swap = b.swap;
        for rec in raw.chunks_exact(w as usize) {
            tags.push(u64_at(rec, swap));
            nodes.extend(rec[8..].chunks_exact(8).map(|c| u64_at(c, swap)));
        }
        if let Some(ix) = index {
            if let Some(i) = nodes.iter().position(|&v| ix.get(v).is_none()) {
                let e = i / k.max(1);
                return Err(Fail::bin(
                    base + e * w as usize + 8 * (1 + i % k.max(1)),
                    ErrorKind::MissingNode {
                        element: tags.get(e).copied().unwrap_or(0),
                        node: nodes[i],
                    },
                ));
            }
        }
        found += n as u64;
        mesh.element_blocks.push(ElementBlock {
            entity_dim,
            entity_tag,
            element_type: ty as u32,
            tags,
            nodes,
            partitions: None,
        });
    }
    if found != total {
        return Err(Fail::bin(
            header_pos,
            ErrorKind::CountMismatch {
                what: "number of elements".into(),
                declared: total,
                found,
            },
        ));
    }
    Ok(())
}

/// `$Periodic` (ASCII 4.1): `n`, per link `dim tag masterTag`, `numAffine value…`,
/// `numNodes`, then `node masterNode` pairs. The 4.0 / 2.2 form (`Affine v…` line, optional)
/// is accepted too.
pub(crate) fn periodic_ascii(t: &mut Text, mesh: &mut Mesh) -> PResult<()> {
    let n = t.count("number of periodic links")?;
    for _ in 0..n {
        let dim = t.i32("entity dimension")?;
        let tag = t.i32("entity tag")?;
        let master_tag = t.i32("master entity tag")?;
        t.skip_ws();
        let mut affine = None;
        let rest = &t.d[t.p..];
        if rest.starts_with(b"Affine") {
            t.token("Affine")?;
            let mut v = Vec::with_capacity(16);
            for _ in 0..16 {
                v.push(t.f64("affine value")?);
            }
            affine = Some(v);
            t.skip_ws();
        }
        let mut count = t.count("number of values or nodes")?;
        if affine.is_none() && looks_like_affine_count(t, count) {
            let mut v = Vec::with_capacity(count);
            for _ in 0..count {
                v.push(t.f64("affine value")?);
            }
            if count > 0 {
                affine = Some(v);
            }
            count = t.count("number of periodic nodes")?;
        }
        let mut node_pairs = Vec::with_capacity(count);
        for _ in 0..count {
            node_pairs.push((t.u64("node tag")?, t.u64("master node tag")?));
        }
        mesh.periodic.push(PeriodicLink {
            dim,
            tag,
            master_tag,
            affine,
            node_pairs,
        });
    }
    Ok(())
}

/// In 4.1 the count after the link header is `numAffine` (0 or 16) followed by that many
/// values and then `numNodes`; in the older form it is directly `numNodes`. Decides which by
/// looking at the rest of the line: the 4.1 affine count stands alone only when it is 0.
fn looks_like_affine_count(t: &Text, count: usize) -> bool {
    // 4.1: "16 v1 ... v16" on one line, or "0" alone followed by the node count line.
    let line_end = memchr::memchr(b'\n', &t.d[t.p..]).map_or(t.d.len(), |i| t.p + i);
    let rest = &t.d[t.p..line_end];
    let more_on_line = rest.iter().any(|b| !b.is_ascii_whitespace());
    if count == 16 && more_on_line {
        return true;
    }
    if count == 0 && !more_on_line {
        // "0" then a count line, then pairs: distinguish from an old-form link with no node
        // by peeking at the next line holding a single integer.
        let mut p = Text::new(t.d, line_end);
        p.skip_ws();
        let start = p.p;
        let line_end2 = memchr::memchr(b'\n', &t.d[start..]).map_or(t.d.len(), |i| start + i);
        let toks = t.d[start..line_end2]
            .split(|b| b.is_ascii_whitespace())
            .filter(|s| !s.is_empty())
            .count();
        return toks == 1;
    }
    false
}

/// `$Periodic` (binary 4.1): `size_t n`, per link `int dim, int tag, int master`,
/// `size_t numAffine` and doubles, `size_t numNodes` and `size_t` pairs.
pub(crate) fn periodic_binary(b: &mut Bin, mesh: &mut Mesh) -> PResult<()> {
    let n = b.count("number of periodic links", 28)?;
    for _ in 0..n {
        let dim = b.i32("entity dimension")?;
        let tag = b.i32("entity tag")?;
        let master_tag = b.i32("master entity tag")?;
        let na = b.count("number of affine values", 8)?;
        let base = b.p;
        let raw = b.take(8 * na as u64, "affine values")?;
        let mut v = Vec::new();
        f64s_into(raw, base, b.swap, "affine value", &mut v)?;
        let nn = b.count("number of periodic nodes", 16)?;
        let raw = b.take(16 * nn as u64, "periodic node pairs")?;
        let node_pairs = raw
            .chunks_exact(16)
            .map(|c| (u64_at(c, b.swap), u64_at(&c[8..], b.swap)))
            .collect();
        mesh.periodic.push(PeriodicLink {
            dim,
            tag,
            master_tag,
            affine: (na > 0).then_some(v),
            node_pairs,
        });
    }
    Ok(())
}
