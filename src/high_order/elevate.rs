//! Step 3 of the module doc: the second-order elements on the input's curved geometry.

use super::*;

/// How a mid-edge node is placed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum MidKind {
    /// The input's mid-edge node, kept.
    Kept(u64),
    /// On an input line3 chain.
    Curve,
    /// On the input's curved surface.
    Surface,
    /// Straight midpoint (no curved geometry known).
    Plain,
}

pub(super) struct Edge {
    a: u64,
    b: u64,
    kind: MidKind,
    curved: DVec3,
    straight: bool,
    /// Entity the mid-edge node is classified on.
    owner: (i32, i32),
    /// A surface holding the edge (the first quad's), where its node is projected.
    surface: Option<i32>,
}

/// Step 3 of the module doc: the second-order mesh from the linear job's result `out`
/// (`linear_max`: the largest node tag of the linear copy it started from).
pub fn elevate(
    input: &Mesh,
    mut out: Mesh,
    linear_max: u64,
    opts: ElevateOptions,
) -> Result<(Mesh, SecondOrderReport), HighOrderError> {
    let input_max = input.max_node_tag();
    // new nodes of the linear job above the input's tags
    let shift = input_max.saturating_sub(linear_max);
    if shift > 0 {
        let up = |t: &mut u64| {
            if *t > linear_max {
                *t += shift;
            }
        };
        for b in &mut out.node_blocks {
            b.tags.iter_mut().for_each(up);
        }
        for b in &mut out.element_blocks {
            b.nodes.iter_mut().for_each(up);
        }
        for l in &mut out.periodic {
            for (a, b) in &mut l.node_pairs {
                up(a);
                up(b);
            }
        }
    }
    let geo = Geometry::new(input);
    // an input mid-edge node whose edge the linear job split becomes the middle corner of
    // the split chain
    let taken = take_split_mid_nodes(&mut out, &geo, input_max);
    // the linear job's nodes (flat positions)
    let flat = NodeTable::new(&out);
    let pos = |t: u64| flat.at(t).unwrap_or(DVec3::ZERO);
    let moved = |t: u64| geo.at(t).is_none_or(|c| Some(c) != flat.at(t));

    // the quads and curve lines of the result
    let mut quads: Vec<(i32, [u64; 4])> = Vec::new();
    let mut quad_at: Vec<(usize, usize)> = Vec::new();
    let mut lines: Vec<(i32, [u64; 2])> = Vec::new();
    for (bi, b) in out.element_blocks.iter().enumerate() {
        match (b.entity_dim, b.element_type) {
            (2, etype::QUAD4) => {
                for (i, e) in b.nodes.chunks_exact(4).enumerate() {
                    quads.push((b.entity_tag, [e[0], e[1], e[2], e[3]]));
                    quad_at.push((bi, i));
                }
            }
            (1, etype::LINE2) => {
                for e in b.nodes.chunks_exact(2) {
                    lines.push((b.entity_tag, [e[0], e[1]]));
                }
            }
            _ => {}
        }
    }

    // curve nodes: chains of new segments between the ends of an input line3
    let mut curve_pos: FastMap<u64, DVec3> = FastMap::default();
    let mut curve_mid: FastMap<(u64, u64), DVec3> = FastMap::default();
    let mut adjacency: FastMap<(i32, u64), Vec<u64>> = FastMap::default();
    for &(c, [a, b]) in &lines {
        adjacency.entry((c, a)).or_default().push(b);
        adjacency.entry((c, b)).or_default().push(a);
    }
    for (&c, list) in &geo.curves {
        for &[a, b, m] in list {
            // a line naming a node the file does not have gets no curved geometry
            let (Some(xa), Some(xb), Some(xm)) = (geo.at(a), geo.at(b), geo.at(m)) else {
                continue;
            };
            if moved(a) || moved(b) {
                continue;
            }
            let is_new = |t: u64| geo.at(t).is_none() || taken.contains(&t);
            let Some(chain) = chain_between(&adjacency, c, a, b, &is_new) else {
                continue;
            };
            let pts: Vec<DVec3> = chain.iter().map(|&t| pos(t)).collect();
            let xi = chain_parameters(&pts);
            for (k, &t) in chain.iter().enumerate() {
                if k > 0 && k + 1 < chain.len() {
                    curve_pos.insert(t, line3_point(xa, xb, xm, xi[k]));
                }
                if k + 1 < chain.len() {
                    let mid_xi = 0.5 * (xi[k] + xi[k + 1]);
                    curve_mid.insert(key(t, chain[k + 1]), line3_point(xa, xb, xm, mid_xi));
                }
            }
        }
    }

    // corners: kept, on a curve, or lifted onto the curved surface
    let mut surface_of: FastMap<u64, i32> = FastMap::default();
    for &(s, q) in &quads {
        for t in q {
            surface_of.entry(t).or_insert(s);
        }
    }
    let mut candidates: Vec<u64> = out
        .node_blocks
        .iter()
        .flat_map(|b| b.tags.iter().copied())
        .filter(|&t| moved(t))
        .collect();
    candidates.sort_unstable();
    candidates.dedup();
    let placed: Vec<(u64, DVec3)> = candidates
        .par_iter()
        .filter_map(|&t| {
            if let Some(&p) = curve_pos.get(&t) {
                return Some((t, p));
            }
            let s = surface_of.get(&t)?;
            let p = geo.surfaces.get(s)?.project(pos(t), &[t])?;
            Some((t, p))
        })
        .collect();
    // corners on the curved geometry: the lifted ones, else the flat positions
    let mut lifted_at: FastMap<u64, DVec3> = FastMap::default();
    for &(t, p) in &placed {
        if p.is_finite() && p != pos(t) {
            lifted_at.insert(t, p);
        }
    }
    let lifted = &lifted_at;
    let corner_at = |t: u64| lifted_at.get(&t).copied().unwrap_or_else(|| pos(t));

    // edges
    let mut edge_of: FastMap<(u64, u64), usize> = FastMap::default();
    let mut edges: Vec<Edge> = Vec::new();
    let mut new_edge = |a: u64, b: u64, owner: (i32, i32), edges: &mut Vec<Edge>| -> usize {
        *edge_of.entry(key(a, b)).or_insert_with(|| {
            edges.push(Edge {
                a,
                b,
                kind: MidKind::Plain,
                curved: DVec3::ZERO,
                straight: false,
                owner,
                surface: None,
            });
            edges.len() - 1
        })
    };
    let mut line_edges = Vec::with_capacity(lines.len());
    for &(c, [a, b]) in &lines {
        line_edges.push(new_edge(a, b, (1, c), &mut edges));
    }
    // entity of every node of the result, for edges along curves without line elements
    let node_entity: FastMap<u64, (i32, i32)> = out
        .node_blocks
        .iter()
        .flat_map(|b| {
            b.tags
                .iter()
                .map(move |&t| (t, (b.entity_dim, b.entity_tag)))
        })
        .collect();
    let bounds = |curve: i32, point: i32| {
        out.entity(1, curve)
            .is_some_and(|e| e.bounding.iter().any(|&p| p.abs() == point))
    };
    // a new edge whose ends are on one curve (or on it and a point bounding it) is a piece
    // of a split curve segment: its mid-edge node is classified on the curve, as Gmsh does
    let edge_owner = |a: u64, b: u64, s: i32| -> (i32, i32) {
        match (node_entity.get(&a), node_entity.get(&b)) {
            (Some(&(1, x)), Some(&(1, y))) if x == y => (1, x),
            (Some(&(1, x)), Some(&(0, p))) | (Some(&(0, p)), Some(&(1, x))) if bounds(x, p) => {
                (1, x)
            }
            _ => (2, s),
        }
    };
    let mut quad_edges = Vec::with_capacity(quads.len());
    for &(s, q) in &quads {
        let mut e = [0usize; 4];
        for k in 0..4 {
            let (a, b) = (q[k], q[(k + 1) % 4]);
            e[k] = new_edge(a, b, edge_owner(a, b, s), &mut edges);
        }
        for &i in &e {
            edges[i].surface.get_or_insert(s);
        }
        quad_edges.push(e);
    }
    edges.par_iter_mut().for_each(|e| {
        let k = key(e.a, e.b);
        let at = corner_at;
        let mid_pt = (at(e.a) + at(e.b)) * 0.5;
        if let (false, false, Some(&m)) = (moved(e.a), moved(e.b), geo.mid.get(&k)) {
            if let Some(x) = geo.at(m) {
                e.kind = MidKind::Kept(m);
                e.curved = x;
                return;
            }
        }
        if let Some(&x) = curve_mid.get(&k) {
            e.kind = MidKind::Curve;
            e.curved = x;
            return;
        }
        if let Some(s) = e.surface {
            if let Some(x) = geo
                .surfaces
                .get(&s)
                .and_then(|g| g.project(mid_pt, &[e.a, e.b]))
            {
                e.kind = MidKind::Surface;
                e.curved = x;
                return;
            }
        }
        e.kind = MidKind::Plain;
        e.curved = mid_pt;
    });
    // a curve edge that is also a quad edge: classified on the curve (first owner wins)

    let complete = !opts.incomplete;
    // the face node: the serendipity centre of the curved corners and mid-edge nodes (a
    // curved edge's bulge spreads evenly over the element), projected onto the surface
    // an input 9-node quad kept with its corners in place keeps its face node
    let face_kept: Vec<Option<u64>> = quads
        .iter()
        .map(|&(_, q)| {
            if !complete || q.iter().any(|&t| moved(t)) {
                return None;
            }
            let mut k = q;
            k.sort_unstable();
            geo.face.get(&k).copied().filter(|&t| geo.at(t).is_some())
        })
        .collect();
    let mut face: Vec<DVec3> = if complete {
        quads
            .par_iter()
            .enumerate()
            .map(|(i, &(s, q))| {
                if let Some(x) = face_kept[i].and_then(|t| geo.at(t)) {
                    return x;
                }
                let mut x = [DVec3::ZERO; 9];
                for k in 0..4 {
                    x[k] = corner_at(q[k]);
                    x[4 + k] = edges[quad_edges[i][k]].curved;
                }
                let c = serendipity_centre(&x);
                geo.surfaces
                    .get(&s)
                    .and_then(|g| g.project(c, &q))
                    .unwrap_or(c)
            })
            .collect()
    } else {
        Vec::new()
    };
    let mut face_straight = vec![!complete; quads.len()];
    face.resize(quads.len(), DVec3::ZERO);

    // validity: straighten, then put corners back, until every element is valid
    let mut reverted: FastSet<u64> = FastSet::default();
    let mut straight_elems: FastSet<u64> = FastSet::default();
    let mut bad_quads: Vec<usize>;
    let mut bad_lines: Vec<usize>;
    let node = |t: u64, reverted: &FastSet<u64>| {
        if reverted.contains(&t) {
            pos(t)
        } else {
            corner_at(t)
        }
    };
    let mid_of = |e: &Edge, reverted: &FastSet<u64>| {
        if e.straight {
            (node(e.a, reverted) + node(e.b, reverted)) * 0.5
        } else {
            e.curved
        }
    };
    let quad_points = |i: usize, edges: &[Edge], fs: &[bool], rv: &FastSet<u64>| -> [DVec3; 9] {
        let q = quads[i].1;
        let mut x = [DVec3::ZERO; 9];
        for k in 0..4 {
            x[k] = node(q[k], rv);
            x[4 + k] = mid_of(&edges[quad_edges[i][k]], rv);
        }
        x[8] = if fs[i] {
            serendipity_centre(&x)
        } else {
            face[i]
        };
        x
    };
    let mut rounds = 0;
    loop {
        rounds += 1;
        bad_quads = (0..quads.len())
            .into_par_iter()
            .filter(|&i| {
                let x = quad_points(i, &edges, &face_straight, &reverted);
                let q = quads[i].1;
                let flat_n = (pos(q[2]) - pos(q[0])).cross(pos(q[3]) - pos(q[1]));
                !quad_valid(&x, flat_n)
            })
            .collect();
        bad_lines = (0..lines.len())
            .filter(|&i| {
                let [a, b] = lines[i].1;
                let e = &edges[line_edges[i]];
                !line_valid(node(a, &reverted), node(b, &reverted), mid_of(e, &reverted))
            })
            .collect();
        if (bad_quads.is_empty() && bad_lines.is_empty()) || rounds > 12 {
            break;
        }
        let mut changed = false;
        for &i in &bad_lines {
            let e = &mut edges[line_edges[i]];
            if !e.straight {
                e.straight = true;
                changed = true;
            } else {
                for t in [e.a, e.b] {
                    if lifted.contains_key(&t) && reverted.insert(t) {
                        changed = true;
                    }
                }
            }
        }
        for &i in &bad_quads {
            let all_straight = face_straight[i] && quad_edges[i].iter().all(|&e| edges[e].straight);
            if !all_straight {
                face_straight[i] = true;
                for &e in &quad_edges[i] {
                    edges[e].straight = true;
                }
                changed = true;
            } else {
                for t in quads[i].1 {
                    if lifted.contains_key(&t) && reverted.insert(t) {
                        changed = true;
                    }
                }
            }
        }
        // nodes placed from a corner now put back: straight around that corner
        if !reverted.is_empty() {
            for e in edges.iter_mut() {
                if reverted.contains(&e.a) || reverted.contains(&e.b) {
                    e.straight = true;
                }
            }
            for (i, (_, q)) in quads.iter().enumerate() {
                if q.iter().any(|t| reverted.contains(t)) {
                    face_straight[i] = true;
                }
            }
        }
        if !changed {
            break;
        }
    }
    // which elements ended up with straight-sided new nodes
    for (i, &(bi, ei)) in quad_at.iter().enumerate() {
        let straight = quad_edges[i]
            .iter()
            .any(|&e| edges[e].straight && edges[e].kind != MidKind::Plain)
            || (complete && face_straight[i]);
        if straight {
            straight_elems.insert(out.element_blocks[bi].tags[ei]);
        }
    }
    let mut bad_tags: Vec<(i32, i32, u64)> = Vec::new();
    for &i in &bad_quads {
        let (bi, ei) = quad_at[i];
        let b = &out.element_blocks[bi];
        bad_tags.push((b.entity_dim, b.entity_tag, b.tags[ei]));
    }
    if !bad_lines.is_empty() {
        let mut k = 0;
        for b in &out.element_blocks {
            if (b.entity_dim, b.element_type) != (1, etype::LINE2) {
                continue;
            }
            for &t in &b.tags {
                if bad_lines.binary_search(&k).is_ok() {
                    bad_tags.push((1, b.entity_tag, t));
                }
                k += 1;
            }
        }
    }
    if let (false, false, Some(first)) = (opts.allow_invalid, bad_tags.is_empty(), bad_tags.first())
    {
        return Err(HighOrderError::Invalid {
            dim: first.0,
            entity: first.1,
            element: first.2,
            count: bad_tags.len(),
        });
    }

    // quality at the nodes
    let sj: Vec<f64> = (0..quads.len())
        .into_par_iter()
        .map(|i| {
            let x = quad_points(i, &edges, &face_straight, &reverted);
            min_scaled_jacobian_at_nodes(&x)
        })
        .collect();

    // new node tags and placement
    let mut next = out.max_node_tag().max(input_max) + 1;
    let mut report = SecondOrderReport {
        quad_type: if complete { etype::QUAD9 } else { etype::QUAD8 },
        quads: quads.len(),
        lines: lines.len(),
        corners_reverted: reverted.len(),
        min_scaled_jacobian: sj.iter().copied().fold(f64::INFINITY, f64::min),
        mean_scaled_jacobian: if sj.is_empty() {
            0.0
        } else {
            sj.iter().sum::<f64>() / sj.len() as f64
        },
        ..Default::default()
    };
    if sj.is_empty() {
        report.min_scaled_jacobian = 0.0;
    }
    let out_index = out.node_index();
    let mut block_of: FastMap<(i32, i32), usize> = FastMap::default();
    for (bi, b) in out.node_blocks.iter().enumerate() {
        block_of.entry((b.entity_dim, b.entity_tag)).or_insert(bi);
    }
    // (entity dim, entity tag, node tag, coordinates, parametric coordinates)
    type NewNode = (i32, i32, u64, DVec3, Option<Vec<f64>>);
    let mut additions: Vec<NewNode> = Vec::new();
    let old_blocks = out.node_blocks.clone();
    let params_for = |owner: (i32, i32), parents: &[u64]| -> Option<Vec<f64>> {
        let bi = *block_of.get(&owner)?;
        old_blocks[bi].params.as_ref()?;
        let np = owner.0.max(0) as usize;
        Some(crate::mesh::mean_params(&old_blocks, &out_index, bi, np, parents).0)
    };
    let mut edge_tag = vec![0u64; edges.len()];
    for (i, e) in edges.iter().enumerate() {
        match (e.kind, e.straight) {
            (MidKind::Kept(m), false) => {
                edge_tag[i] = m;
                report.kept_mid_nodes += 1;
                let (d, t, p) = geo.owner(m).unwrap_or((e.owner.0, e.owner.1, None));
                additions.push((d, t, m, e.curved, p));
            }
            (kind, straight) => {
                edge_tag[i] = next;
                next += 1;
                match (kind, straight) {
                    (MidKind::Curve, false) => report.curve_mid_nodes += 1,
                    (MidKind::Surface, false) => report.surface_mid_nodes += 1,
                    _ => {}
                }
                let x = mid_of(e, &reverted);
                additions.push((
                    e.owner.0,
                    e.owner.1,
                    edge_tag[i],
                    x,
                    params_for(e.owner, &[e.a, e.b]),
                ));
            }
        }
    }
    let mut face_tag = vec![0u64; quads.len()];
    if complete {
        for i in 0..quads.len() {
            let x = quad_points(i, &edges, &face_straight, &reverted)[8];
            let s = quads[i].0;
            if let (Some(t), false) = (face_kept[i], face_straight[i]) {
                face_tag[i] = t;
                report.kept_face_nodes += 1;
                let (d, e, p) = geo.owner(t).unwrap_or((2, s, None));
                additions.push((d, e, t, x, p));
                continue;
            }
            face_tag[i] = next;
            next += 1;
            report.face_nodes += 1;
            additions.push((2, s, face_tag[i], x, params_for((2, s), &quads[i].1)));
        }
    }
    // corners placed on the curved geometry
    let mut corners_placed = 0usize;
    for b in &mut out.node_blocks {
        for (i, &t) in b.tags.iter().enumerate() {
            if lifted.contains_key(&t) && !reverted.contains(&t) {
                if let Some(p) = lifted_at.get(&t) {
                    b.coords[i] = p.to_array();
                }
                corners_placed += 1;
            }
        }
    }
    report.corners_placed = corners_placed;
    for (d, t, tag, x, p) in additions {
        let bi = *block_of.entry((d, t)).or_insert_with(|| {
            out.node_blocks.push(NodeBlock {
                entity_dim: d,
                entity_tag: t,
                tags: Vec::new(),
                coords: Vec::new(),
                params: None,
            });
            out.node_blocks.len() - 1
        });
        let blk = &mut out.node_blocks[bi];
        let np = d.max(0) as usize;
        if let Some(params) = blk.params.as_mut() {
            let mut p = p.unwrap_or_default();
            p.resize(np, 0.0);
            params.extend_from_slice(&p);
        }
        blk.tags.push(tag);
        blk.coords.push(x.to_array());
    }

    // elements
    let mut qi = 0usize;
    let mut li = 0usize;
    let qtype = report.quad_type;
    for b in &mut out.element_blocks {
        match (b.entity_dim, b.element_type) {
            (2, etype::QUAD4) => {
                let k = if complete { 9 } else { 8 };
                let mut nodes = Vec::with_capacity(b.len() * k);
                for e in b.nodes.chunks_exact(4) {
                    nodes.extend_from_slice(e);
                    for &ei in &quad_edges[qi] {
                        nodes.push(edge_tag[ei]);
                    }
                    if complete {
                        nodes.push(face_tag[qi]);
                    }
                    qi += 1;
                }
                b.nodes = nodes;
                b.element_type = qtype;
            }
            (1, etype::LINE2) => {
                let mut nodes = Vec::with_capacity(b.len() * 3);
                for e in b.nodes.chunks_exact(2) {
                    nodes.extend_from_slice(e);
                    nodes.push(edge_tag[line_edges[li]]);
                    li += 1;
                }
                b.nodes = nodes;
                b.element_type = etype::LINE3;
            }
            _ => {}
        }
    }

    // periodic links: kept pairs of kept mid nodes, new pairs of new mid and face nodes
    let present: FastSet<u64> = out
        .node_blocks
        .iter()
        .flat_map(|b| b.tags.iter().copied())
        .collect();
    let edge_index: FastMap<(u64, u64), usize> = edges
        .iter()
        .enumerate()
        .map(|(i, e)| (key(e.a, e.b), i))
        .collect();
    let face_by_corners: FastMap<[u64; 4], u64> = if complete {
        quads
            .iter()
            .zip(&face_tag)
            .map(|((_, q), &t)| {
                let mut s = *q;
                s.sort_unstable();
                (s, t)
            })
            .collect()
    } else {
        FastMap::default()
    };
    for (li, link) in out.periodic.iter_mut().enumerate() {
        let map: FastMap<u64, u64> = link.node_pairs.iter().copied().collect();
        let mut pairs = link.node_pairs.clone();
        if let Some(orig) = input.periodic.get(li) {
            for &(a, b) in &orig.node_pairs {
                if !map.contains_key(&a) && present.contains(&a) && present.contains(&b) {
                    pairs.push((a, b));
                }
            }
        }
        for (e, &t) in edges.iter().zip(&edge_tag) {
            if e.owner != (link.dim, link.tag) {
                continue;
            }
            if let (Some(&ma), Some(&mb)) = (map.get(&e.a), map.get(&e.b)) {
                if let Some(&mi) = edge_index.get(&key(ma, mb)) {
                    // only a master node on the master entity
                    if edges[mi].owner == (link.dim, link.master_tag) && !map.contains_key(&t) {
                        pairs.push((t, edge_tag[mi]));
                    }
                }
            }
        }
        if complete && link.dim == 2 {
            for ((s, q), &t) in quads.iter().zip(&face_tag) {
                if *s != link.tag {
                    continue;
                }
                let mapped: Option<Vec<u64>> = q.iter().map(|c| map.get(c).copied()).collect();
                if let Some(m) = mapped {
                    let mut k = [m[0], m[1], m[2], m[3]];
                    k.sort_unstable();
                    if let Some(&mt) = face_by_corners.get(&k) {
                        pairs.push((t, mt));
                    }
                }
            }
        }
        pairs.retain(|(a, b)| present.contains(a) && present.contains(b));
        link.node_pairs = pairs;
    }

    // $NodeData that named input mid-edge nodes no longer there
    let lost = geo.mid.values().any(|m| !present.contains(m));
    if lost
        && out
            .data_sections
            .iter()
            .any(|d| d.kind == crate::mesh::DataKind::Node)
    {
        out.data_sections
            .retain(|d| d.kind != crate::mesh::DataKind::Node);
        out.warnings.push(
            "dropped the $NodeData section(s): some of their nodes (mid-edge nodes of edges the recombination removed) are gone".into(),
        );
    }

    let mut straight: Vec<u64> = straight_elems.into_iter().collect();
    straight.sort_unstable();
    report.straight = straight;
    report.invalid = bad_tags.iter().map(|b| b.2).collect();
    Ok((out, report))
}
