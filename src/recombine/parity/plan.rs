//! The plan: the odd regions, the groups of boundary segments that flip the same regions,
//! and the segments chosen to make every region even.

use super::*;

/// Finds the odd regions and a set of segments whose splits make all of them even: a
/// T-join on the graph whose nodes are the regions plus a "ground" node (see module doc).
/// A segment in `avoid` (sorted edge keys) is split only when no other segment flips the
/// same regions.
pub(crate) fn plan(mesh: &Mesh, nodes: &NodeTable, work: &[SurfaceWork], avoid: &[u64]) -> Plan {
    // regions, their sizes and owners
    let mut offset = Vec::with_capacity(work.len());
    let mut region_surface: Vec<(i32, usize, usize)> = Vec::new();
    let mut size: Vec<usize> = Vec::new();
    for w in work {
        offset.push(size.len() as u32);
        for r in 0..w.n_regions {
            region_surface.push((w.tag, r, w.n_regions));
            size.push(0);
        }
        let base = size.len() - w.n_regions;
        for &r in &w.region {
            size[base + r as usize] += 1;
        }
    }
    let nr = size.len();
    let odd_of = |r: usize| OddRegion {
        surface: region_surface[r].0,
        region: (region_surface[r].1, region_surface[r].2),
        triangles: size[r],
    };
    let odd: Vec<OddRegion> = (0..nr).filter(|&r| size[r] % 2 == 1).map(odd_of).collect();
    if odd.is_empty() {
        return Plan {
            odd,
            choices: Vec::new(),
            columns: Vec::new(),
            unsolved: Vec::new(),
            isolated: Vec::new(),
        };
    }
    // wall half-edges with their region, and whether their triangle is an "ear" (two or
    // three wall edges) or a few graph steps from one: splitting a segment of an ear leaves
    // a half with a single graph neighbour, the other half, so the matching must merge them
    // back into a "quad" with a straight angle at the new node, and an ear nearby forces its
    // neighbours' matches in a chain that often ends the same way; such segments are split
    // only when no other will do
    let mut walls: Vec<(u64, u32, bool)> = Vec::new();
    for (w, &off) in work.iter().zip(&offset) {
        let near_ear = near_ears(&w.topo, 3);
        for (t, &ear) in near_ear.iter().enumerate() {
            let nb = &w.topo.nbr[3 * t..3 * t + 3];
            for k in 0..3 {
                if nb[k] == NONE {
                    let tri = w.topo.tris[t];
                    walls.push((edge_key(tri[k], tri[(k + 1) % 3]), off + w.region[t], ear));
                }
            }
        }
    }
    walls.sort_unstable();
    let blocked = blocked_edges(mesh, nodes);
    let line_curve = line_curves(mesh, nodes);
    let curve_of = |key: u64| segment_curve(mesh, nodes, &line_curve, key);
    // regions flipped by splitting the segment `key` (odd number of triangles on it)
    let sig_of = |key: u64| -> Vec<u32> {
        let lo = walls.partition_point(|x| x.0 < key);
        let hi = walls.partition_point(|x| x.0 <= key);
        walls[lo..hi]
            .chunk_by(|x, y| x.1 == y.1)
            .filter(|r| r.len() % 2 == 1)
            .map(|r| r[0].1)
            .collect()
    };
    let periodic = PeriodicCurves::new(mesh, nodes);
    let periodic_surfaces = PeriodicSurfaces::new(mesh, nodes);
    let mut groups: HashMap<(Option<i32>, Vec<u32>), usize> = HashMap::new();
    let mut list: Vec<Group> = Vec::new();
    let mut segments: Vec<column::Segment> = Vec::new();
    for run in walls.chunk_by(|x, y| x.0 == y.0) {
        let key = run[0].0;
        if blocked.binary_search(&key).is_ok() {
            continue;
        }
        let (a, b) = ((key >> 32) as u32, key as u32);
        let curve = curve_of(key);
        let mut sig = sig_of(key);
        // a segment of a periodic curve is split together with its images on the curves
        // linked to it; the split flips the regions of all of them
        let mut with: Vec<(u32, u32, Option<i32>)> = Vec::new();
        let mut class = curve;
        if let Some(c) = curve.filter(|&c| periodic.has(c)) {
            let Some(images) = periodic.images(c, a, b) else {
                continue;
            };
            for &(c2, x, y) in &images {
                let k2 = edge_key(x, y);
                if blocked.binary_search(&k2).is_ok() {
                    sig.clear();
                    break;
                }
                sig = xor_sorted(&sig, &sig_of(k2));
                with.push((x, y, Some(c2)));
            }
            class = images.iter().map(|i| i.0).chain([c]).min();
        } else if !periodic_surfaces.is_empty() {
            // a segment on the boundary of a periodic surface whose curve is not known
            // (no curve data, e.g. MSH 2.2 without line elements): split together with its
            // images through the surface links, so the slave stays the master's image
            let Some(images) = periodic_surfaces.images(a, b) else {
                continue;
            };
            for &(x, y) in &images {
                let k2 = edge_key(x, y);
                if blocked.binary_search(&k2).is_ok() {
                    sig.clear();
                    break;
                }
                sig = xor_sorted(&sig, &sig_of(k2));
                with.push((x, y, None));
            }
        }
        if sig.is_empty() {
            continue;
        }
        let len = (nodes.coords[a as usize] - nodes.coords[b as usize]).length();
        let no_ear = run.iter().all(|x| !x.2);
        let wanted = avoid.binary_search(&key).is_err();
        let id = *groups.entry((class, sig.clone())).or_insert_with(|| {
            list.push(Group {
                curve,
                sig,
                best: (false, false, -1.0, a, b),
                with: Vec::new(),
            });
            list.len() - 1
        });
        if with.is_empty() {
            segments.push(column::Segment {
                key,
                group: id,
                wanted,
                no_ear,
            });
        }
        let best = list[id].best;
        if (wanted, no_ear, len) > (best.0, best.1, best.2) {
            list[id].best = (wanted, no_ear, len, a, b);
            list[id].curve = curve;
            list[id].with = with;
        }
    }
    let odd_in: Vec<bool> = size.iter().map(|s| s % 2 == 1).collect();
    let mut cost = column::group_costs(work, &offset, nodes, &list, &segments, &odd_in);
    let (mut chosen, mut unsolved_ids) = solve_groups(&list, &odd_in, &cost);
    // a mixed surface left odd is retriangulated and recombined whole (see `recombine`),
    // which gives better quads than a chord through its own quads; chords are for triangle
    // surfaces bordered by other surfaces' quads (structured `Layers`/`Recombine` faces)
    let mixed = |r: u32| {
        let s = region_surface[r as usize].0;
        work.iter().any(|w| w.tag == s && w.quads_kept > 0)
    };
    if !unsolved_ids.is_empty() && !blocked.is_empty() && !unsolved_ids.iter().any(|&r| mixed(r)) {
        // segments bordered by quads: the split runs through the quad strip (chord) that
        // starts there, splitting each quad into two, until it leaves the quads
        // a chord edge is on a curve when a line element holds it or both ends are
        // classified on that curve (no line elements)
        let chord_curve = |key: u64| -> Option<i32> {
            match line_curve.binary_search_by_key(&key, |x| x.0) {
                Ok(p) => Some(line_curve[p].1),
                Err(_) => match (
                    nodes.entity(mesh, (key >> 32) as u32),
                    nodes.entity(mesh, key as u32),
                ) {
                    ((1, c), (1, d)) if c == d => Some(c),
                    _ => None,
                },
            }
        };
        let chords = quad_chords(
            mesh,
            nodes,
            &walls,
            &blocked,
            &curve_of,
            &chord_curve,
            &periodic,
        );
        let mut by_sig: HashMap<Vec<u32>, usize> = HashMap::new();
        for ch in chords {
            let sig = ch.iter().fold(Vec::new(), |acc, e| {
                xor_sorted(&acc, &sig_of(edge_key(e.0, e.1)))
            });
            if sig.is_empty() {
                continue;
            }
            match by_sig.get(&sig) {
                Some(&g) if list[g].with.len() <= ch.len() => {}
                _ => {
                    let (a, b, curve) = ch[0];
                    let grp = Group {
                        curve,
                        sig: sig.clone(),
                        best: (true, true, 0.0, a, b),
                        with: ch[1..].to_vec(),
                    };
                    match by_sig.get(&sig) {
                        Some(&g) => list[g] = grp,
                        None => {
                            by_sig.insert(sig, list.len());
                            list.push(grp);
                        }
                    }
                }
            }
        }
        cost.resize(list.len(), column::SPLIT_COST);
        (chosen, unsolved_ids) = solve_groups(&list, &odd_in, &cost);
    }
    let mut touched = vec![false; nr];
    for g in &list {
        for &r in &g.sig {
            touched[r as usize] = true;
        }
    }
    let isolated: Vec<bool> = unsolved_ids.iter().map(|&r| !touched[r as usize]).collect();
    let unsolved: Vec<OddRegion> = unsolved_ids
        .into_iter()
        .map(|r| odd_of(r as usize))
        .collect();
    // a group chosen twice cancels out
    chosen.sort_unstable();
    let keep: Vec<usize> = chosen
        .chunk_by(|a, b| a == b)
        .filter(|r| r.len() % 2 == 1)
        .map(|r| r[0])
        .collect();
    let columns = column::columns(work, &offset, nodes, &mut list, &keep, &segments);
    column::place_single_splits(work, &offset, nodes, &mut list, &keep, &segments, &columns);
    let choices = keep
        .into_iter()
        .map(|g| {
            let grp = &list[g];
            let mut surfaces: Vec<i32> = grp
                .sig
                .iter()
                .map(|&r| region_surface[r as usize].0)
                .collect();
            surfaces.sort_unstable();
            surfaces.dedup();
            Choice {
                a: grp.best.3,
                b: grp.best.4,
                curve: grp.curve,
                surfaces,
                with: grp.with.clone(),
            }
        })
        .collect();
    Plan {
        odd,
        choices,
        columns,
        unsolved,
        isolated,
    }
}

/// The curve of the wall segment `key` (an edge key of node ids): the curve of its line
/// element (`line_curve`, from [`line_curves`]), else of a node classified on a curve, else
/// the curve bounded by both its nodes' points (a curve meshed with one segment).
pub(super) fn segment_curve(
    mesh: &Mesh,
    nodes: &NodeTable,
    line_curve: &[(u64, i32)],
    key: u64,
) -> Option<i32> {
    let (a, b) = ((key >> 32) as u32, key as u32);
    match line_curve.binary_search_by_key(&key, |x| x.0) {
        Ok(p) => Some(line_curve[p].1),
        Err(_) => match (nodes.entity(mesh, a), nodes.entity(mesh, b)) {
            ((1, c), _) | (_, (1, c)) => Some(c),
            // a curve meshed with one segment: the curve bounded by both points
            ((0, p), (0, q)) => mesh.entities[1]
                .iter()
                .find(|c| {
                    let pts: Vec<i32> = c.bounding.iter().map(|x| x.abs()).collect();
                    pts.len() == 2 && pts.contains(&p) && pts.contains(&q)
                })
                .map(|c| c.tag),
            _ => None,
        },
    }
}

/// Triangles within `depth` graph steps of an *ear* (a triangle with two or three wall
/// edges), found by a breadth-first search from all ears.
pub(super) fn near_ears(topo: &crate::recombine::topology::SurfaceTopo, depth: u8) -> Vec<bool> {
    let n = topo.len();
    let mut dist = vec![u8::MAX; n];
    let mut queue: Vec<usize> = (0..n)
        .filter(|&t| {
            topo.nbr[3 * t..3 * t + 3]
                .iter()
                .filter(|&&x| x == NONE)
                .count()
                >= 2
        })
        .collect();
    for &t in &queue {
        dist[t] = 0;
    }
    let mut head = 0;
    while head < queue.len() {
        let t = queue[head];
        head += 1;
        if dist[t] >= depth {
            continue;
        }
        for &u in &topo.nbr[3 * t..3 * t + 3] {
            if u != NONE && dist[u as usize] == u8::MAX {
                dist[u as usize] = dist[t] + 1;
                queue.push(u as usize);
            }
        }
    }
    dist.into_iter().map(|d| d <= depth).collect()
}

/// Keys of edges of 2D elements other than 3-node triangles (quads …): splitting them would
/// leave a hanging node.
pub(super) fn blocked_edges(mesh: &Mesh, nodes: &NodeTable) -> Vec<u64> {
    let mut out = Vec::new();
    for b in &mesh.element_blocks {
        if b.entity_dim != 2 || b.element_type == etype::TRI3 {
            continue;
        }
        let k = b.nodes_per_element();
        let corners = if b.element_type == etype::QUAD4 { 4 } else { k };
        for i in 0..b.len() {
            let e = b.element(i);
            let ids: Vec<u32> = e.iter().filter_map(|&t| nodes.id(t)).collect();
            if ids.len() != e.len() || corners == 0 {
                continue;
            }
            for c in 0..corners {
                out.push(edge_key(ids[c], ids[(c + 1) % corners]));
            }
        }
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// `(edge key, curve tag)` of every 2-node line element, sorted by key.
pub(super) fn line_curves(mesh: &Mesh, nodes: &NodeTable) -> Vec<(u64, i32)> {
    let mut out = Vec::new();
    for b in &mesh.element_blocks {
        if b.element_type != etype::LINE2 {
            continue;
        }
        for i in 0..b.len() {
            let e = b.element(i);
            if let (Some(x), Some(y)) = (nodes.id(e[0]), nodes.id(e[1])) {
                out.push((edge_key(x, y), b.entity_tag));
            }
        }
    }
    out.sort_unstable();
    out
}
