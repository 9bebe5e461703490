//! The parity system (eq. 5-6) solved: T-joins on the region graph, and GF(2) elimination
//! where a segment flips more than two regions.

use super::*;

/// Fallback T-join over a spanning forest (used when the odd regions are too many for
/// [`min_tjoin`] or some cannot be paired): odd parity is pushed from the leaves to the root
/// of each tree; a root left odd is fixed through a ground group reached along the tree.
/// Returns the chosen groups (with repeats) and the roots that stay odd.
pub(super) fn tree_tjoin(
    adj: &[Vec<(u32, usize)>],
    odd: &[bool],
    ground: u32,
) -> (Vec<usize>, Vec<u32>) {
    let nr = odd.len();
    let mut parity: Vec<bool> = odd.to_vec();
    parity.push(false);
    let mut seen = vec![false; nr + 1];
    let mut chosen: Vec<usize> = Vec::new();
    let mut unsolved: Vec<u32> = Vec::new();
    for start in 0..nr {
        if seen[start] {
            continue;
        }
        // component over region-region edges
        let mut comp = vec![start as u32];
        seen[start] = true;
        let mut parent: HashMap<u32, (u32, usize)> = HashMap::new();
        let mut q = 0;
        while q < comp.len() {
            let u = comp[q];
            q += 1;
            for &(v, g) in &adj[u as usize] {
                if v != ground && !seen[v as usize] {
                    seen[v as usize] = true;
                    parent.insert(v, (u, g));
                    comp.push(v);
                }
            }
        }
        if !comp.iter().any(|&r| parity[r as usize]) {
            continue;
        }
        // re-root at a region with a ground group, when there is one, by pushing the
        // odd parity along tree paths to `start` and then from `start` to that region
        for &u in comp.iter().skip(1).rev() {
            if parity[u as usize] {
                let (p, g) = parent[&u];
                parity[u as usize] = false;
                parity[p as usize] ^= true;
                chosen.push(g);
            }
        }
        if parity[start] {
            let ground_at = comp.iter().find_map(|&r| {
                adj[r as usize]
                    .iter()
                    .find(|&&(v, _)| v == ground)
                    .map(|&(_, g)| (r, g))
            });
            match ground_at {
                Some((r, g)) => {
                    // path start -> r in the tree: toggle edges from r up to start
                    let mut x = r;
                    while x != start as u32 {
                        let (p, pg) = parent[&x];
                        chosen.push(pg);
                        x = p;
                    }
                    chosen.push(g);
                    parity[start] = false;
                }
                None => unsolved.push(start as u32),
            }
        }
    }
    (chosen, unsolved)
}

/// Minimum T-join (cheapest splits): the odd regions are paired, or paired with the
/// ground, by a minimum-cost perfect matching on shortest-path distances in the region
/// graph, each group costing `cost[g]` (each odd region `i` has a ground twin `K + i` joined
/// to it at its distance to the ground; twins are joined to each other at cost 0), then the
/// groups along each pair's shortest path are chosen. Among paths of equal cost the first
/// found in breadth-first order is taken (with equal costs, the fewest splits and the
/// breadth-first tree). `None` when there are too many odd regions or no pairing exists.
pub(super) fn min_tjoin(
    adj: &[Vec<(u32, usize)>],
    odd: &[u32],
    ground: u32,
    cost: &[i64],
) -> Option<Vec<usize>> {
    let k = odd.len();
    let nr = adj.len();
    if k == 0 {
        return Some(Vec::new());
    }
    if k > 1500 {
        return None;
    }
    // Dijkstra from each odd region over region-region edges (not through the ground),
    // ties popped in the order found
    let search = |src: u32| -> (Vec<i64>, Vec<(u32, usize)>, Vec<u32>) {
        let mut dist = vec![i64::MAX; nr];
        let mut parent = vec![(NONE, 0usize); nr];
        let mut order = Vec::new();
        let mut heap = std::collections::BinaryHeap::new();
        let mut seq = 0u64;
        dist[src as usize] = 0;
        heap.push(std::cmp::Reverse((0i64, seq, src)));
        while let Some(std::cmp::Reverse((d, _, u))) = heap.pop() {
            if d > dist[u as usize] {
                continue;
            }
            order.push(u);
            for &(v, g) in &adj[u as usize] {
                let nd = d + cost[g];
                if v != ground && nd < dist[v as usize] {
                    dist[v as usize] = nd;
                    parent[v as usize] = (u, g);
                    seq += 1;
                    heap.push(std::cmp::Reverse((nd, seq, v)));
                }
            }
        }
        (dist, parent, order)
    };
    // the cheapest group joining region `r` to the ground (the first of equal ones)
    let ground_group = |r: u32| {
        adj[r as usize]
            .iter()
            .filter(|e| e.0 == ground)
            .min_by_key(|e| cost[e.1])
            .map(|e| e.1)
    };
    // the region where the path to the ground leaves the graph: least distance plus
    // ground group, the first in search order of equal ones
    let exit = |dist: &[i64], order: &[u32]| {
        order
            .iter()
            .filter_map(|&r| ground_group(r).map(|g| (dist[r as usize] + cost[g], r, g)))
            .min_by_key(|x| x.0)
    };
    let mut edges: Vec<(u32, u32, i64)> = Vec::new();
    for (i, &src) in odd.iter().enumerate() {
        let (dist, _, order) = search(src);
        for (j, &dst) in odd.iter().enumerate().skip(i + 1) {
            if dist[dst as usize] != i64::MAX {
                edges.push((i as u32, j as u32, dist[dst as usize]));
            }
        }
        if let Some((d, _, _)) = exit(&dist, &order) {
            edges.push((i as u32, (k + i) as u32, d));
        }
        for j in i + 1..k {
            edges.push(((k + i) as u32, (k + j) as u32, 0));
        }
    }
    let m = crate::matching::solve(2 * k, &edges).ok()?;
    let mut chosen = Vec::new();
    for (i, &src) in odd.iter().enumerate() {
        let mate = m.mate[i] as usize;
        if mate < i {
            continue;
        }
        let (dist, parent, order) = search(src);
        let end = if mate < k {
            odd[mate]
        } else {
            let (_, r, g) = exit(&dist, &order)?;
            chosen.push(g);
            r
        };
        let mut x = end;
        while x != src {
            let (p, g) = parent[x as usize];
            if p == NONE {
                return None;
            }
            chosen.push(g);
            x = p;
        }
    }
    Some(chosen)
}

/// The root of `x` in the union-find forest `uf` (each entry its parent, a root its own),
/// halving the path on the way.
pub(super) fn find(uf: &mut [u32], mut x: u32) -> u32 {
    while uf[x as usize] != x {
        let p = uf[uf[x as usize] as usize];
        uf[x as usize] = p;
        x = p;
    }
    x
}

/// Chooses groups (with repeats, which cancel) whose splits make every region even, given
/// each group's flipped regions (`sig`) and the odd regions. Returns the choice and the odd
/// regions left that no choice can fix (empty exactly when the GF(2) system "the chosen
/// groups flip every odd region an odd number of times and every even one an even number"
/// is solvable).
///
/// Groups flipping one or two regions are the edges of the region graph (a one-region
/// group joins its region to the ground). Inside one connected component of that graph any
/// even set of odd regions can be fixed along paths, and any set at all when the component
/// holds the ground; so the only constraint is one parity bit per ungrounded component.
/// Groups flipping three or more regions (curves shared by 3+ surfaces) change those bits:
/// a small GF(2) system (rows: ungrounded components, columns: such groups, cheapest
/// first), solved by Gaussian elimination, picks the ones to split; their flips are
/// applied, and the region graph's minimum T-join fixes the rest with the fewest splits.
pub(crate) fn solve_groups(
    list: &[Group],
    odd_in: &[bool],
    cost: &[i64],
) -> (Vec<usize>, Vec<u32>) {
    let nr = odd_in.len();
    let ground = nr as u32;
    // components of the region graph
    let mut uf: Vec<u32> = (0..=nr as u32).collect();
    let mut adj: Vec<Vec<(u32, usize)>> = vec![Vec::new(); nr + 1];
    for (g, grp) in list.iter().enumerate() {
        let (u, v) = match grp.sig.len() {
            1 => (grp.sig[0], ground),
            2 => (grp.sig[0], grp.sig[1]),
            _ => continue,
        };
        adj[u as usize].push((v, g));
        adj[v as usize].push((u, g));
        let (ru, rv) = (find(&mut uf, u), find(&mut uf, v));
        if ru != rv {
            uf[ru as usize] = rv;
        }
    }
    let ground_root = find(&mut uf, ground);
    let comp: Vec<u32> = (0..nr as u32).map(|r| find(&mut uf, r)).collect();
    // dense numbering of the ungrounded components
    let mut row_of = vec![NONE; nr + 1];
    let mut n_rows = 0usize;
    for &c in &comp {
        if c != ground_root && row_of[c as usize] == NONE {
            row_of[c as usize] = n_rows as u32;
            n_rows += 1;
        }
    }
    let mut rhs = vec![false; n_rows];
    for r in 0..nr {
        let row = row_of[comp[r] as usize];
        if odd_in[r] && row != NONE {
            rhs[row as usize] ^= true;
        }
    }
    let mut odd = odd_in.to_vec();
    let mut chosen: Vec<usize> = Vec::new();
    if rhs.iter().any(|&b| b) {
        // columns: groups flipping 3+ regions, by the ungrounded components they flip
        let mut cols: Vec<(usize, Vec<u32>)> = Vec::new();
        for (g, grp) in list.iter().enumerate() {
            if grp.sig.len() < 3 {
                continue;
            }
            let mut rows: Vec<u32> = grp
                .sig
                .iter()
                .map(|&r| row_of[comp[r as usize] as usize])
                .filter(|&x| x != NONE)
                .collect();
            rows.sort_unstable();
            let rows: Vec<u32> = rows
                .chunk_by(|a, b| a == b)
                .filter(|c| c.len() % 2 == 1)
                .map(|c| c[0])
                .collect();
            if !rows.is_empty() {
                cols.push((g, rows));
            }
        }
        // the cheapest groups first: the elimination takes a column as a pivot in order, so
        // of groups that fix the same components the cheapest is taken (the inner circle of
        // an odd annulus band rather than its longer outer one, see `group_costs`)
        cols.sort_by_key(|c| (cost[c.0], c.0));
        let x = gf2_solve(
            n_rows,
            &cols.iter().map(|c| c.1.clone()).collect::<Vec<_>>(),
            &rhs,
        );
        for (j, (g, _)) in cols.iter().enumerate() {
            if x[j] {
                chosen.push(*g);
                for &r in &list[*g].sig {
                    odd[r as usize] ^= true;
                }
            }
        }
    }
    // components still odd cannot be fixed: their odd regions are reported, and left out of
    // the T-join (one per component would make it impossible)
    let mut left = vec![false; n_rows];
    for r in 0..nr {
        let row = row_of[comp[r] as usize];
        if odd[r] && row != NONE {
            left[row as usize] ^= true;
        }
    }
    let mut unsolved: Vec<u32> = Vec::new();
    for r in 0..nr {
        let row = row_of[comp[r] as usize];
        if row != NONE && left[row as usize] && odd[r] {
            unsolved.push(r as u32);
            odd[r] = false;
        }
    }
    let odd_ids: Vec<u32> = (0..nr as u32).filter(|&r| odd[r as usize]).collect();
    match min_tjoin(&adj, &odd_ids, ground, cost) {
        Some(c) => chosen.extend(c),
        None => {
            let (c, u) = tree_tjoin(&adj, &odd, ground);
            chosen.extend(c);
            unsolved.extend(u);
        }
    }
    unsolved.sort_unstable();
    unsolved.dedup();
    (chosen, unsolved)
}

/// Solves `A x = b` over GF(2) by Gaussian elimination; `cols[j]` lists the rows where
/// column `j` has a 1. Free variables are 0. When the system is inconsistent, the returned
/// `x` satisfies the rows it can (the caller checks what is left).
pub(super) fn gf2_solve(n_rows: usize, cols: &[Vec<u32>], b: &[bool]) -> Vec<bool> {
    let nc = cols.len();
    let words = (nc + 1).div_ceil(64);
    let mut m = vec![0u64; n_rows * words];
    for (j, c) in cols.iter().enumerate() {
        for &r in c {
            m[r as usize * words + j / 64] ^= 1 << (j % 64);
        }
    }
    for (r, &v) in b.iter().enumerate() {
        if v {
            m[r * words + nc / 64] ^= 1 << (nc % 64);
        }
    }
    let bit = |m: &[u64], r: usize, j: usize| (m[r * words + j / 64] >> (j % 64)) & 1 == 1;
    let mut pivot_row = 0;
    let mut pivots: Vec<(usize, usize)> = Vec::new();
    for j in 0..nc {
        let Some(p) = (pivot_row..n_rows).find(|&r| bit(&m, r, j)) else {
            continue;
        };
        if p != pivot_row {
            for w in 0..words {
                m.swap(p * words + w, pivot_row * words + w);
            }
        }
        for r in 0..n_rows {
            if r != pivot_row && bit(&m, r, j) {
                for w in 0..words {
                    let v = m[pivot_row * words + w];
                    m[r * words + w] ^= v;
                }
            }
        }
        pivots.push((pivot_row, j));
        pivot_row += 1;
        if pivot_row == n_rows {
            break;
        }
    }
    let mut x = vec![false; nc];
    for (r, j) in pivots {
        x[j] = bit(&m, r, nc);
    }
    x
}

/// Symmetric difference of two sorted lists.
pub(super) fn xor_sorted(x: &[u32], y: &[u32]) -> Vec<u32> {
    let mut out = Vec::with_capacity(x.len() + y.len());
    let (mut i, mut j) = (0, 0);
    while i < x.len() || j < y.len() {
        if j == y.len() || (i < x.len() && x[i] < y[j]) {
            out.push(x[i]);
            i += 1;
        } else if i == x.len() || y[j] < x[i] {
            out.push(y[j]);
            j += 1;
        } else {
            i += 1;
            j += 1;
        }
    }
    out
}
