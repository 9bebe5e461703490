//! The input's mid-edge nodes on split boundary edges, handed to the middle new corner of
//! the chain that replaced the edge (module doc, step 3), and the parameters of such chains.

use super::*;

/// Gives the mid-edge node of each input boundary edge (a 3-node line's, or a face edge
/// used once on its surface) that the linear job split (parity repair, the fallback,
/// refinement: a chain of an even number of pieces between the edge's two unmoved ends,
/// through new nodes only, along edges on the result's boundary, the edge itself gone) to
/// the chain's middle node: it takes the mid-edge node's tag and input coordinates (on the
/// curved geometry, where the linear job put it on the chord or on the curve), so the
/// input's node is the new corner. Returns the tags given. Nodes above `input_max` are the
/// linear job's new ones.
pub(super) fn take_split_mid_nodes(out: &mut Mesh, geo: &Geometry, input_max: u64) -> HashSet<u64> {
    let flat = NodeTable::new(out);
    // the result's boundary edges: line elements, and quad edges used once on their
    // surface; each node's neighbours along them
    let mut edges: HashSet<(u64, u64)> = HashSet::new();
    let mut face_uses: FastMap<(i32, (u64, u64)), u32> = FastMap::default();
    for b in &out.element_blocks {
        let ring: &[usize] = match (b.entity_dim, b.element_type) {
            (2, etype::QUAD4) => &[0, 1, 2, 3],
            (1, etype::LINE2) => &[0, 1],
            _ => continue,
        };
        let k = b.nodes_per_element();
        for e in b.nodes.chunks_exact(k) {
            for (j, &i) in ring.iter().enumerate() {
                let (x, y) = (e[i], e[ring[(j + 1) % ring.len()]]);
                if x == y {
                    continue;
                }
                edges.insert(key(x, y));
                let tag = if b.entity_dim == 2 { b.entity_tag } else { -1 };
                *face_uses.entry((tag, key(x, y))).or_default() += 1;
            }
        }
    }
    let mut along: FastMap<u64, Vec<u64>> = FastMap::default();
    for (&(s, (x, y)), &n) in &face_uses {
        if s == -1 || n == 1 {
            along.entry(x).or_default().push(y);
            along.entry(y).or_default().push(x);
        }
    }
    for v in along.values_mut() {
        v.sort_unstable();
        v.dedup();
    }
    // the input's boundary edges: 3-node lines, face edges used once on their surface
    let mut boundary: HashSet<(u64, u64)> = HashSet::new();
    let mut uses: FastMap<(i32, (u64, u64)), u32> = FastMap::default();
    for b in &geo.input.element_blocks {
        let corners = match (b.entity_dim, b.element_type) {
            (1, etype::LINE3) => {
                for e in b.nodes.chunks_exact(3) {
                    boundary.insert(key(e[0], e[1]));
                }
                continue;
            }
            (2, etype::TRI6) => 3,
            (2, etype::QUAD9 | etype::QUAD8) => 4,
            _ => continue,
        };
        for e in b.nodes.chunks_exact(b.nodes_per_element()) {
            for j in 0..corners {
                *uses
                    .entry((b.entity_tag, key(e[j], e[(j + 1) % corners])))
                    .or_default() += 1;
            }
        }
    }
    boundary.extend(uses.into_iter().filter(|x| x.1 == 1).map(|x| (x.0).1));
    let present: HashSet<u64> = out
        .node_blocks
        .iter()
        .flat_map(|b| b.tags.iter().copied())
        .collect();
    // the chain of new nodes from `a` to `b` along the result's boundary (at most
    // `MAX_PIECES` pieces), its inner nodes in order
    const MAX_PIECES: usize = 64;
    let chain = |a: u64, b: u64| -> Option<Vec<u64>> {
        for &first in along.get(&a)? {
            let (mut prev, mut at) = (a, first);
            let mut inner = Vec::new();
            while at > input_max && inner.len() < MAX_PIECES {
                inner.push(at);
                // a new node on a boundary has two neighbours along it (both surfaces of
                // a shared curve see the same two)
                let next = along.get(&at).and_then(|v| {
                    let mut it = v.iter().filter(|&&x| x != prev);
                    let n = it.next().copied();
                    n.filter(|_| it.next().is_none())
                });
                let Some(next) = next else { break };
                (prev, at) = (at, next);
            }
            if at == b && !inner.is_empty() {
                return Some(inner);
            }
        }
        None
    };
    // new node -> (mid-edge node, its coordinates)
    let mut take: FastMap<u64, (u64, DVec3)> = FastMap::default();
    let mut given: HashSet<u64> = HashSet::new();
    let mut split: Vec<(u64, u64)> = boundary
        .iter()
        .copied()
        .filter(|e| !edges.contains(e))
        .collect();
    split.sort_unstable();
    for (a, b) in split {
        let Some(&m) = geo.mid.get(&key(a, b)) else {
            continue;
        };
        let (Some(xa), Some(xb), Some(xm)) = (flat.at(a), flat.at(b), geo.at(m)) else {
            continue;
        };
        // both ends where the input has them, the mid-edge node not used by the result
        if geo.at(a) != Some(xa) || geo.at(b) != Some(xb) || present.contains(&m) {
            continue;
        }
        let Some(inner) = chain(a, b) else { continue };
        if inner.len() % 2 == 0 {
            continue;
        }
        let n = inner[inner.len() / 2];
        let Some(p) = flat.at(n) else { continue };
        // the middle node between the ends: within the middle half of the chord, off it
        // by less than half its length
        let d = xb - xa;
        let u = (p - xa).dot(d) / d.length_squared();
        let between = (0.25..=0.75).contains(&u) && (p - xa - d * u).length() < 0.5 * d.length();
        if between && !take.contains_key(&n) && given.insert(m) {
            take.insert(n, (m, xm));
        }
    }
    if take.is_empty() {
        return HashSet::new();
    }
    let rename = |t: &mut u64| {
        if let Some(&(m, _)) = take.get(t) {
            *t = m;
        }
    };
    for b in &mut out.node_blocks {
        for (t, c) in b.tags.iter_mut().zip(b.coords.iter_mut()) {
            if let Some(&(m, x)) = take.get(t) {
                *t = m;
                *c = x.to_array();
            }
        }
    }
    for b in &mut out.element_blocks {
        b.nodes.iter_mut().for_each(rename);
    }
    for l in &mut out.periodic {
        for (a, b) in &mut l.node_pairs {
            rename(a);
            rename(b);
        }
    }
    out.invalidate_element_data();
    given
}

/// The chain of curve-`c` nodes from `a` to `b` through nodes `is_new` accepts, following
/// the result's line elements (`adjacency`); `None` when `a` and `b` are not joined so.
pub(super) fn chain_between(
    adjacency: &FastMap<(i32, u64), Vec<u64>>,
    c: i32,
    a: u64,
    b: u64,
    is_new: &dyn Fn(u64) -> bool,
) -> Option<Vec<u64>> {
    let first = adjacency.get(&(c, a))?;
    for &n in first {
        if n == b {
            // the input segment is still one segment
            return Some(vec![a, b]);
        }
        if !is_new(n) {
            continue;
        }
        let mut chain = vec![a, n];
        let mut prev = a;
        let mut cur = n;
        loop {
            let next = adjacency
                .get(&(c, cur))
                .and_then(|v| v.iter().copied().find(|&x| x != prev));
            match next {
                Some(x) if x == b => {
                    chain.push(b);
                    return Some(chain);
                }
                Some(x) if is_new(x) && chain.len() < 1 << 12 => {
                    chain.push(x);
                    prev = cur;
                    cur = x;
                }
                _ => break,
            }
        }
    }
    None
}

/// Line3 parameters (in [-1, 1]) of the nodes of a chain from its chord-length fractions,
/// snapped to the dyadic fractions that midpoint splits make when that keeps them in order.
pub(super) fn chain_parameters(pts: &[DVec3]) -> Vec<f64> {
    let mut s = vec![0.0; pts.len()];
    for k in 1..pts.len() {
        s[k] = s[k - 1] + pts[k].distance(pts[k - 1]);
    }
    let total = s.last().copied().unwrap_or(0.0);
    let n = pts.len();
    let t: Vec<f64> = if total > 0.0 {
        s.iter().map(|x| x / total).collect()
    } else {
        (0..n).map(|k| k as f64 / (n.max(2) - 1) as f64).collect()
    };
    for m in 1..=10 {
        let d = f64::from(1u32 << m);
        let snapped: Vec<f64> = t.iter().map(|x| (x * d).round() / d).collect();
        let ordered = snapped.windows(2).all(|w| w[0] < w[1]);
        let close = t
            .iter()
            .zip(&snapped)
            .all(|(x, y)| (x - y).abs() <= 0.3 / d);
        if ordered && close {
            return snapped.iter().map(|x| 2.0 * x - 1.0).collect();
        }
    }
    t.iter().map(|x| 2.0 * x - 1.0).collect()
}
