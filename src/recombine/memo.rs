//! The matchings of surfaces already recombined in the same run, found again by what they
//! were computed from (the pipeline's fallback recombines every surface in each of its
//! rounds, and most surfaces come back unchanged but for their global node ids, which the
//! splits elsewhere shift).
//!
//! **What stays true:** a surface's graph, matching, quads and strip plans
//! ([`super::surface`] steps 4–7, [`super::strip::plans`]) read only its triangles (as
//! global node ids, through their coordinates), its adjacency (its regions and strips come
//! from it), which of its nodes are split nodes, the priced-out quads among its nodes and
//! the options below; none of them orders anything by a global node id. So two surfaces
//! equal in those, read in local ids (each node numbered by its first appearance in the
//! triangle list), get the same quads in local ids, and a result stored for one is the
//! other's, its ids mapped back. The key is a 128-bit hash of all of it (two SipHash states
//! salted apart); nothing else is compared. A collision would hand a surface quads of
//! another's shape, which the invariants checked after every recombination (conformity,
//! boundaries, areas) refuse.

use std::collections::HashMap;
use std::hash::{Hash, Hasher};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use super::post::Faces;
use super::strip::StripPlan;
use super::topology::SurfaceTopo;
use super::RecombineOptions;

/// Node ids from this up in a stored result are the surface's new nodes (`NEW + j` for its
/// `new_nodes[j]`); below, local ids.
const NEW: u32 = 1 << 31;

/// Stored matchings by key (see the module doc), shared by every round of a run.
#[derive(Default)]
pub(crate) struct MatchMemo {
    stored: Mutex<HashMap<u128, Stored>>,
    /// Surfaces that got a stored matching back.
    hits: AtomicUsize,
}

impl MatchMemo {
    /// How many surfaces got a stored matching back so far.
    pub(crate) fn hits(&self) -> usize {
        self.hits.load(Ordering::Relaxed)
    }
}

/// One surface's quads and strip plans in local ids, and the report figures the matching
/// gave.
struct Stored {
    faces: Faces,
    plans: Vec<StripPlan>,
    figures: Figures,
}

/// What a surface's report takes from its graph and matching.
#[derive(Clone, Copy)]
pub(super) struct Figures {
    pub graph_edges: usize,
    pub extra_edges_added: usize,
    pub matching_cost: i64,
    pub pairs_priced_out: usize,
    pub priced_out_used: usize,
}

/// A surface read in local ids: the key of its matching and the global id of each local one.
pub(super) struct Local {
    key: u128,
    global: Vec<u32>,
    local: HashMap<u32, u32>,
}

impl Local {
    /// Reads surface `tag` (its topology, the coordinates, the split nodes and the movable
    /// nodes ([`RecombineOptions::movable_nodes`]) and priced-out quads of the whole mesh,
    /// all sorted, and the options) in local ids.
    pub(super) fn new(
        tag: i32,
        morton: bool,
        topo: &SurfaceTopo,
        coords: &[glam::DVec3],
        [split_nodes, movable]: [&[u32]; 2],
        priced: &[[u32; 4]],
        opts: &RecombineOptions,
    ) -> Self {
        let mut local: HashMap<u32, u32> = HashMap::with_capacity(topo.tris.len() / 2 + 8);
        let mut global: Vec<u32> = Vec::with_capacity(topo.tris.len() / 2 + 8);
        let mut h = [Hasher2::new(0), Hasher2::new(1)];
        let mut add = |x: &dyn Fn(&mut Hasher2)| h.iter_mut().for_each(x);
        add(&|s| {
            tag.hash(s);
            morton.hash(s);
            topo.tris.len().hash(s);
            topo.nbr.hash(s);
            opts.flat_halves_out.hash(s);
            opts.hopeless_out.binary_search(&tag).is_ok().hash(s);
            opts.cross_field_weight.to_bits().hash(s);
            opts.harmonic_cross_field.hash(s);
            opts.extra_edges.hash(s);
            opts.two_row_strips.hash(s);
            opts.split_matching.hash(s);
        });
        // speed: each part hashed as one slice of integers (one write of its bytes)
        let mut ids: Vec<u32> = Vec::with_capacity(3 * topo.tris.len());
        for t in &topo.tris {
            ids.extend(t.map(|v| {
                *local.entry(v).or_insert_with(|| {
                    global.push(v);
                    global.len() as u32 - 1
                })
            }));
        }
        add(&|s| ids.hash(s));
        drop(ids);
        let mut bits: Vec<u64> = Vec::with_capacity(3 * global.len());
        let mut split: Vec<u8> = Vec::with_capacity(global.len());
        for &v in &global {
            bits.extend(coords[v as usize].to_array().map(f64::to_bits));
            split.push(
                u8::from(split_nodes.binary_search(&v).is_ok())
                    | (u8::from(movable.binary_search(&v).is_ok()) << 1),
            );
        }
        add(&|s| {
            bits.hash(s);
            split.hash(s);
        });
        // the priced-out quads all of whose nodes are the surface's, in local ids
        let mut mine: Vec<[u32; 4]> = priced
            .iter()
            .filter_map(|q| {
                let mut l = [0u32; 4];
                for (x, v) in l.iter_mut().zip(q) {
                    *x = *local.get(v)?;
                }
                l.sort_unstable();
                Some(l)
            })
            .collect();
        mine.sort_unstable();
        add(&|s| mine.hash(s));
        let key = (u128::from(h[0].finish()) << 64) | u128::from(h[1].finish());
        Local { key, global, local }
    }

    /// The stored matching of this surface, if any, with its strip plans, in global ids
    /// (`n_global`: the first id of the surface's new nodes).
    pub(super) fn find(
        &self,
        memo: &MatchMemo,
        n_global: u32,
    ) -> Option<(Faces, Vec<StripPlan>, Figures)> {
        let stored = memo.stored.lock().ok()?;
        let s = stored.get(&self.key)?;
        let id = |v: u32| {
            if v >= NEW {
                n_global + (v - NEW)
            } else {
                self.global[v as usize]
            }
        };
        let faces = s.faces.with_ids(|v| Some(id(v)))?;
        let plans = s
            .plans
            .iter()
            .map(|p| p.with_ids(|v| Some(id(v))))
            .collect::<Option<Vec<_>>>()?;
        memo.hits.fetch_add(1, Ordering::Relaxed);
        Some((faces, plans, s.figures))
    }

    /// Stores `faces` (global ids, new nodes from `n_global`), the strip `plans` made from
    /// them and the report `figures` as this surface's matching. `None` when a node id is neither the surface's nor new (the
    /// result is then not stored).
    pub(super) fn store(
        &self,
        memo: &MatchMemo,
        faces: &Faces,
        plans: &[StripPlan],
        n_global: u32,
        figures: Figures,
    ) -> Option<()> {
        let id = |v: u32| -> Option<u32> {
            if v >= n_global {
                let j = v - n_global;
                (j < NEW).then_some(NEW + j)
            } else {
                self.local.get(&v).copied()
            }
        };
        let faces = faces.with_ids(id)?;
        let plans = plans
            .iter()
            .map(|p| p.with_ids(id))
            .collect::<Option<Vec<_>>>()?;
        let s = Stored {
            faces,
            plans,
            figures,
        };
        memo.stored.lock().ok()?.insert(self.key, s);
        Some(())
    }
}

/// SipHash (the standard library's) with a leading salt, so that two of them with
/// different salts give independent halves of the key.
struct Hasher2(std::collections::hash_map::DefaultHasher);

impl Hasher2 {
    fn new(salt: u64) -> Self {
        let mut h = std::collections::hash_map::DefaultHasher::new();
        salt.hash(&mut h);
        Hasher2(h)
    }
}

impl Hasher for Hasher2 {
    fn finish(&self) -> u64 {
        self.0.finish()
    }
    fn write(&mut self, bytes: &[u8]) {
        self.0.write(bytes);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::testing::{node_block, one_surface};
    use crate::mesh::{etype, Mesh};

    /// A 6 x 6 grid of unit squares, each split along a diagonal that alternates, on
    /// surface 1 (node tags from 1), with `before` nodes first in a block of their own (tags
    /// from 1001, on no element): they shift every global node id of the grid.
    fn grid(before: usize, moved: Option<(u64, [f64; 3])>) -> Mesh {
        let n = 6u64;
        let tag = |i: u64, j: u64| j * (n + 1) + i + 1;
        let mut coords = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                coords.push([i as f64, j as f64, 0.0]);
            }
        }
        if let Some((t, c)) = moved {
            coords[t as usize - 1] = c;
        }
        let mut tris: Vec<[u64; 3]> = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let (a, b, c, d) = (tag(i, j), tag(i + 1, j), tag(i + 1, j + 1), tag(i, j + 1));
                if (i + j) % 2 == 0 {
                    tris.extend([[a, b, c], [a, c, d]]);
                } else {
                    tris.extend([[a, b, d], [b, c, d]]);
                }
            }
        }
        let mut blocks = Vec::new();
        if before > 0 {
            blocks.push(node_block(
                0,
                (1001..1001 + before as u64).collect(),
                (0..before).map(|k| [50.0 + k as f64, 0.0, 0.0]).collect(),
            ));
        }
        blocks.push(node_block(2, (1..=coords.len() as u64).collect(), coords));
        let elems: Vec<&[u64]> = tris.iter().map(|t| &t[..]).collect();
        one_surface(blocks, etype::TRI3, &elems)
    }

    /// The quads of `m` recombined with `memo`, as sorted node tags, sorted.
    fn quads(mut m: Mesh, memo: Option<&MatchMemo>) -> Vec<[u64; 4]> {
        let opts = RecombineOptions {
            cross_field_weight: 0.05,
            ..Default::default()
        };
        super::super::recombine_with(&mut m, &opts, memo).expect("recombines");
        let mut out: Vec<[u64; 4]> = m
            .element_blocks
            .iter()
            .filter(|b| b.element_type == etype::QUAD4)
            .flat_map(|b| (0..b.len()).map(move |i| b.element(i)))
            .map(|e| [e[0], e[1], e[2], e[3]])
            .collect();
        out.sort_unstable();
        out
    }

    #[test]
    fn a_surface_whose_node_ids_shifted_gets_its_stored_matching_back() {
        let memo = MatchMemo::default();
        let first = quads(grid(0, None), Some(&memo));
        assert_eq!(first.len(), 36);
        assert_eq!(memo.hits(), 0);
        // every global id shifted by 7: found again, with the quads a fresh matching gives
        let shifted = quads(grid(7, None), Some(&memo));
        assert_eq!(memo.hits(), 1);
        assert_eq!(shifted, quads(grid(7, None), None));
        assert_eq!(shifted, first);
        // an interior node moved: another surface, matched afresh
        let moved = Some((tag_of(2, 3), [2.2, 3.1, 0.0]));
        let other = quads(grid(7, moved), Some(&memo));
        assert_eq!(memo.hits(), 1);
        assert_eq!(other, quads(grid(7, moved), None));
    }

    fn tag_of(i: u64, j: u64) -> u64 {
        j * 7 + i + 1
    }
}
