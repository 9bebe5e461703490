//! Periodic surfaces (`$Periodic` links of dimension 2): Gmsh meshes the slave surface as
//! the image of its master (every slave triangle maps, through the link's node pairs, onto a
//! master triangle). Only the master is recombined (the slave is left out of the parity
//! system and of the matching); its quads are then mapped onto the slave through the node
//! correspondence, so the output stays periodic. Master nodes without a slave counterpart
//! (vertex duplications, or nodes the optimizer added) get a new slave node at the image of
//! their position through the link's affine transform (or, when the file has none, the
//! translation that all node pairs agree on), and the pair is added to the link.
//!
//! [`map_slaves`] is run again after optimization, which optimizes the master and leaves
//! the slave out: the slave's elements are replaced by the image of the optimized master,
//! its interior nodes moved to the images of the master's, and the slave nodes of master
//! nodes the optimizer removed dropped with their pairs, so master and slave stay
//! consistent whatever the optimizer did to the master.

use std::collections::HashMap;

use glam::DVec3;

use super::RecombineError;
use crate::mesh::{etype, ElementBlock, Mesh, NodeBlock};

/// `(link index, slave, master)` of every surface link whose slave has surface elements,
/// a master that is itself a slave coming before the links that copy from it.
pub(crate) fn slave_links(mesh: &Mesh) -> Vec<(usize, i32, i32)> {
    let mut todo: Vec<(usize, i32, i32)> = mesh
        .periodic
        .iter()
        .enumerate()
        .filter(|(_, l)| l.dim == 2 && l.tag != l.master_tag)
        .filter(|(_, l)| has_faces(mesh, l.tag))
        .map(|(i, l)| (i, l.tag, l.master_tag))
        .collect();
    let mut out = Vec::with_capacity(todo.len());
    while !todo.is_empty() {
        // links whose master is not waiting to be copied itself (a cycle: take the first)
        let ready = todo
            .iter()
            .position(|l| !todo.iter().any(|o| o.1 == l.2))
            .unwrap_or(0);
        out.push(todo.remove(ready));
    }
    out
}

/// `surfaces` with every surface linked to one of them by a link of [`slave_links`]
/// (master or slave, through chains of links).
pub(crate) fn with_partners(
    mesh: &Mesh,
    mut surfaces: std::collections::HashSet<i32>,
) -> std::collections::HashSet<i32> {
    let links = slave_links(mesh);
    loop {
        let before = surfaces.len();
        for &(_, s, m) in &links {
            if surfaces.contains(&s) || surfaces.contains(&m) {
                surfaces.insert(s);
                surfaces.insert(m);
            }
        }
        if surfaces.len() == before {
            return surfaces;
        }
    }
}

/// Slave surfaces left out of the recombination (they get the image of their master).
pub(crate) fn slave_surfaces(mesh: &Mesh) -> Vec<i32> {
    slave_links(mesh).into_iter().map(|l| l.1).collect()
}

fn has_faces(mesh: &Mesh, s: i32) -> bool {
    mesh.element_blocks
        .iter()
        .any(|b| b.entity_tag == s && b.is_linear_face() && !b.is_empty())
}

/// The faces (triangles and quads) of surface `s`, with their tags.
fn faces(mesh: &Mesh, s: i32) -> Vec<(u64, Vec<u64>)> {
    let mut out = Vec::new();
    for b in &mesh.element_blocks {
        if b.entity_tag == s && b.is_linear_face() {
            for i in 0..b.len() {
                out.push((b.tags[i], b.element(i).to_vec()));
            }
        }
    }
    out
}

fn sorted(v: &[u64]) -> Vec<u64> {
    let mut s = v.to_vec();
    s.sort_unstable();
    s
}

/// For every slave surface: master face tag → slave face tag, checking that the slave is
/// the image of its master (same faces through the node pairs). Run on the triangles
/// (after parity repair, before recombination).
pub(crate) fn correspondence(mesh: &Mesh) -> Result<Vec<HashMap<u64, u64>>, RecombineError> {
    let mut out = Vec::new();
    for (li, s, m) in slave_links(mesh) {
        let link = &mesh.periodic[li];
        let s2m: HashMap<u64, u64> = link.node_pairs.iter().copied().collect();
        let master: HashMap<Vec<u64>, u64> = faces(mesh, m)
            .into_iter()
            .map(|(t, n)| (sorted(&n), t))
            .collect();
        let slave = faces(mesh, s);
        let refuse = |why: String| RecombineError::PeriodicSurface {
            surface: s,
            master: m,
            reason: why,
        };
        if slave.len() != master.len() {
            return Err(refuse(format!(
                "it has {} elements and its master {}",
                slave.len(),
                master.len()
            )));
        }
        let mut corr = HashMap::new();
        for (t, n) in &slave {
            let mut img = Vec::with_capacity(n.len());
            for x in n {
                match s2m.get(x) {
                    Some(&y) => img.push(y),
                    None => {
                        return Err(refuse(format!(
                            "node {x} of element {t} has no periodic counterpart"
                        )))
                    }
                }
            }
            match master.get(&sorted(&img)) {
                Some(&mt) => {
                    corr.insert(mt, *t);
                }
                None => {
                    return Err(refuse(format!(
                        "element {t} is not the image of any element of the master"
                    )))
                }
            }
        }
        out.push(corr);
    }
    Ok(out)
}

/// The master → slave map of positions of a link: its affine transform, or else the one
/// translation all node pairs agree on.
fn transform(mesh: &Mesh, li: usize) -> Result<Box<dyn Fn(DVec3) -> DVec3>, String> {
    let link = &mesh.periodic[li];
    if let Some(a) = link.affine.as_ref().filter(|a| a.len() == 16) {
        let a: Vec<f64> = a.clone();
        return Ok(Box::new(move |p: DVec3| {
            DVec3::new(
                a[0] * p.x + a[1] * p.y + a[2] * p.z + a[3],
                a[4] * p.x + a[5] * p.y + a[6] * p.z + a[7],
                a[8] * p.x + a[9] * p.y + a[10] * p.z + a[11],
            )
        }));
    }
    let idx = mesh.node_index();
    let pos = |t: u64| {
        idx.get(t)
            .map(|r| DVec3::from_array(mesh.node_blocks[r.block as usize].coords[r.index as usize]))
    };
    let pairs: Vec<(DVec3, DVec3)> = link
        .node_pairs
        .iter()
        .filter_map(|&(s, m)| Some((pos(s)?, pos(m)?)))
        .collect();
    if pairs.is_empty() {
        return Err("its link has no node pairs".into());
    }
    let d = pairs.iter().map(|(s, m)| *s - *m).sum::<DVec3>() / pairs.len() as f64;
    let scale = pairs.iter().map(|(_, m)| m.length()).fold(1.0, f64::max);
    if pairs
        .iter()
        .any(|(s, m)| (*s - *m - d).length() > 1e-6 * scale)
    {
        return Err(
            "its link has no affine transform and its node pairs are not a translation".into(),
        );
    }
    Ok(Box::new(move |p: DVec3| p + d))
}

/// Replaces every slave surface's elements by the image of its master's (see the module
/// doc). `corr` (from [`correspondence`]) gives the slave tag of each master triangle tag,
/// so each slave quad keeps the tag of one of its triangles; without it, slave elements
/// whose nodes map onto a master face keep their tag and the others get fresh tags.
/// Returns the number of slave surfaces mapped.
pub(crate) fn map_slaves(
    mesh: &mut Mesh,
    corr: Option<&[HashMap<u64, u64>]>,
) -> Result<usize, RecombineError> {
    let links = slave_links(mesh);
    for (k, &(li, s, m)) in links.iter().enumerate() {
        let refuse = |why: String| RecombineError::PeriodicSurface {
            surface: s,
            master: m,
            reason: why,
        };
        let map = transform(mesh, li).map_err(&refuse)?;
        let idx = mesh.node_index();
        // a pair naming a node the mesh lacks is left out (and dropped from the link at the
        // end, `remove_orphans`): its master node gets a new slave node below
        let pairs: Vec<(u64, u64)> = mesh.periodic[li]
            .node_pairs
            .iter()
            .copied()
            .filter(|&(a, b)| idx.get(a).is_some() && idx.get(b).is_some())
            .collect();
        let s2m: HashMap<u64, u64> = pairs.iter().copied().collect();
        let mut m2s: HashMap<u64, u64> = pairs.iter().map(|&(a, b)| (b, a)).collect();
        let master = faces(mesh, m);
        let slave = faces(mesh, s);
        // orientation: directed boundary edges of the master against the slave's
        let mut directed: Vec<(u64, u64)> = Vec::new();
        for (_, f) in &master {
            for j in 0..f.len() {
                directed.push((f[j], f[(j + 1) % f.len()]));
            }
        }
        directed.sort_unstable();
        let has = |e: (u64, u64)| directed.binary_search(&e).is_ok();
        let (mut same, mut opp) = (0usize, 0usize);
        for (_, f) in &slave {
            for j in 0..f.len() {
                let (Some(&a), Some(&b)) = (s2m.get(&f[j]), s2m.get(&f[(j + 1) % f.len()])) else {
                    continue;
                };
                let (fw, bw) = (has((a, b)), has((b, a)));
                if fw && !bw {
                    same += 1;
                } else if bw && !fw {
                    opp += 1;
                }
            }
        }
        if same == 0 && opp == 0 {
            return Err(refuse(
                "its boundary nodes do not map onto the master's boundary".into(),
            ));
        }
        let reverse = opp > same;
        // tags of the current slave elements by the master nodes they map to
        let slave_by_img: HashMap<Vec<u64>, u64> = slave
            .iter()
            .filter_map(|(t, f)| {
                let img: Option<Vec<u64>> = f.iter().map(|x| s2m.get(x).copied()).collect();
                img.map(|i| (sorted(&i), *t))
            })
            .collect();
        let mut used_tags: std::collections::HashSet<u64> = std::collections::HashSet::new();
        let mut next_elem = mesh.max_element_tag() + 1;
        let mut next_node = mesh.max_node_tag() + 1;
        let pos = |t: u64| {
            idx.get(t).map(|r| {
                DVec3::from_array(mesh.node_blocks[r.block as usize].coords[r.index as usize])
            })
        };
        let mut new_nodes: Vec<(u64, DVec3)> = Vec::new();
        let mut new_pairs: Vec<(u64, u64)> = Vec::new();
        let mut out_tri: Vec<(u64, Vec<u64>)> = Vec::new();
        let mut out_quad: Vec<(u64, Vec<u64>)> = Vec::new();
        let mut moved: Vec<(u64, DVec3)> = Vec::new();
        for (mt, f) in &master {
            let mut img = Vec::with_capacity(f.len());
            for &x in f {
                let p = pos(x).ok_or_else(|| refuse(format!("master node {x} does not exist")))?;
                let t = match m2s.get(&x) {
                    Some(&t) => t,
                    None => {
                        let t = next_node;
                        next_node += 1;
                        new_nodes.push((t, map(p)));
                        new_pairs.push((t, x));
                        m2s.insert(x, t);
                        t
                    }
                };
                moved.push((t, map(p)));
                img.push(t);
            }
            if reverse {
                img.reverse();
            }
            let key = sorted(f);
            let tag = corr
                .and_then(|c| c.get(k))
                .and_then(|c| c.get(mt))
                .copied()
                .or_else(|| slave_by_img.get(&key).copied())
                .filter(|t| !used_tags.contains(t))
                .unwrap_or_else(|| {
                    let t = next_elem;
                    next_elem += 1;
                    t
                });
            used_tags.insert(tag);
            if img.len() == 4 {
                out_quad.push((tag, img));
            } else {
                out_tri.push((tag, img));
            }
        }
        drop(idx);
        // interior slave nodes follow the master (curve and point nodes never move)
        let idx = mesh.node_index();
        for (t, p) in moved {
            if let Some(r) = idx.get(t) {
                let b = &mut mesh.node_blocks[r.block as usize];
                if b.entity_dim == 2 && b.entity_tag == s {
                    b.coords[r.index as usize] = p.to_array();
                }
            }
        }
        // new slave nodes
        if !new_nodes.is_empty() {
            let bi = match mesh
                .node_blocks
                .iter()
                .position(|b| b.entity_dim == 2 && b.entity_tag == s)
            {
                Some(bi) => bi,
                None => {
                    mesh.node_blocks.push(NodeBlock {
                        entity_dim: 2,
                        entity_tag: s,
                        tags: Vec::new(),
                        coords: Vec::new(),
                        params: None,
                    });
                    mesh.node_blocks.len() - 1
                }
            };
            let b = &mut mesh.node_blocks[bi];
            let np = b.params.as_ref().map(|p| p.len() / b.tags.len().max(1));
            for (t, p) in &new_nodes {
                b.tags.push(*t);
                b.coords.push(p.to_array());
                if let (Some(params), Some(np)) = (b.params.as_mut(), np) {
                    params.extend(std::iter::repeat_n(0.0, np));
                }
            }
            mesh.periodic[li].node_pairs.extend(new_pairs);
        }
        // replace the slave's elements
        let first = mesh
            .element_blocks
            .iter()
            .position(|b| b.entity_dim == 2 && b.entity_tag == s)
            .unwrap_or(mesh.element_blocks.len());
        mesh.element_blocks
            .retain(|b| !(b.entity_tag == s && b.is_linear_face()));
        let at = first.min(mesh.element_blocks.len());
        for (ty, list) in [(etype::TRI3, out_tri), (etype::QUAD4, out_quad)] {
            if list.is_empty() {
                continue;
            }
            let block = ElementBlock {
                entity_dim: 2,
                entity_tag: s,
                element_type: ty,
                tags: list.iter().map(|x| x.0).collect(),
                nodes: list.iter().flat_map(|x| x.1.iter().copied()).collect(),
                partitions: None,
            };
            mesh.element_blocks.insert(at, block);
        }
        remove_orphans(mesh, li, s);
    }
    mesh.invalidate_element_data();
    Ok(links.len())
}

/// Drops the nodes classified on surface `s` that no element uses any more, and their
/// pairs in link `li` ([`drop_missing_pairs`]).
fn remove_orphans(mesh: &mut Mesh, li: usize, s: i32) {
    drop_unused_nodes(mesh, s);
    drop_missing_pairs(mesh, li);
}

/// Drops every pair of link `li` that names a node the mesh does not have: one dropped
/// with its surface's unused nodes, or missing from a surface's earlier optimized state
/// put back by a fallback job.
fn drop_missing_pairs(mesh: &mut Mesh, li: usize) {
    let idx = mesh.node_index();
    let exists = |t: u64| idx.get(t).is_some();
    let pairs: Vec<(u64, u64)> = mesh.periodic[li]
        .node_pairs
        .iter()
        .copied()
        .filter(|&(a, b)| exists(a) && exists(b))
        .collect();
    drop(idx);
    mesh.periodic[li].node_pairs = pairs;
}

/// Drops the nodes classified on surface `s` that no element uses.
fn drop_unused_nodes(mesh: &mut Mesh, s: i32) {
    let Some(bi) = mesh
        .node_blocks
        .iter()
        .position(|b| b.entity_dim == 2 && b.entity_tag == s)
    else {
        return;
    };
    let mut used: Vec<u64> = mesh
        .element_blocks
        .iter()
        .flat_map(|b| b.nodes.iter().copied())
        .collect();
    used.sort_unstable();
    used.dedup();
    let is_used = |t: u64| used.binary_search(&t).is_ok();
    let b = &mesh.node_blocks[bi];
    if b.tags.iter().all(|&t| is_used(t)) {
        return;
    }
    let np = b.params.as_ref().map(|p| p.len() / b.tags.len().max(1));
    let keep: Vec<bool> = b.tags.iter().map(|&t| is_used(t)).collect();
    let b = &mut mesh.node_blocks[bi];
    let mut i = 0;
    b.tags.retain(|_| {
        i += 1;
        keep[i - 1]
    });
    let mut i = 0;
    b.coords.retain(|_| {
        i += 1;
        keep[i - 1]
    });
    if let (Some(p), Some(np)) = (b.params.as_mut(), np) {
        let old = std::mem::take(p);
        for (j, k) in keep.iter().enumerate() {
            if *k {
                p.extend_from_slice(&old[j * np..(j + 1) * np]);
            }
        }
    }
}
