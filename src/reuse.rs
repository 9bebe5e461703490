//! A surface's optimized quads kept between the jobs of one run (the fallback's rounds and
//! the worst-quad tries of the main job): a surface whose recombined quads, nodes and
//! coordinates are the same as in an earlier job is not optimized again; its optimized
//! state from that job is put back instead.
//!
//! The same means: the same quads in the same order over the same nodes at the same
//! coordinates, where the nodes and elements the job made (tags above the input's largest)
//! may carry other tags (a split elsewhere shifts the tags given after it). Those are
//! matched by their place in the surface's blocks, and the optimized state put back
//! carries the tags of the current job. A surface that a job optimizes with other options
//! (`OptimizeOptions::located_surfaces`, which the fallback sets in later rounds) gets a
//! salted fingerprint ([`Fingerprints::with_variant`]): it is never given that surface
//! optimized with the others.
//!
//! This is exact, not an approximation: the optimizer of a surface reads only that
//! surface's quads, the nodes they use, the input (its reference) and its options, in block
//! order, and moves only the nodes that no other element uses; so the same recombined
//! surface gives the same optimized surface. Its options include the mesh's worst quad
//! after the first schedules (`OptimizeOptions::trial_worst`, which decides whether a small
//! planar surface tries three schedules): the pipeline measures it in the run's first
//! optimization and gives that value to every later one. A surface is kept only when its node blocks
//! hold no node that another entity's elements use and its quads use no node of another
//! surface's node block, so that putting back its node blocks and quad blocks changes
//! nothing else; except a node that the quads of both surfaces use (a fallback split's node
//! on a curve one segment long, which has no node block, lands in the block of one of its
//! surfaces): it lies on the boundary of both surfaces' quads, so neither optimizer moves
//! it, and it keeps the coordinates both fingerprints hold.
//!
//! The validity check is skipped the same way: a state put back that passed it in an
//! earlier job's output of the same check key ([`SurfaceCache::passed`]) passes it again,
//! since the check of a surface reads only its quads, their coordinates, the input and
//! that key.

use std::collections::{HashMap, HashSet};
use std::hash::{DefaultHasher, Hash, Hasher};

use crate::mesh::{etype, ElementBlock, Mesh, NodeBlock, TagCoords};

/// The tags of the nodes and elements a job made (above the input's largest), in the order
/// a surface's blocks list them: its quad blocks (element tag, then node tags) and then its
/// node blocks.
#[derive(Debug, Clone, Default, PartialEq)]
struct Made {
    nodes: Vec<u64>,
    elements: Vec<u64>,
}

/// Fingerprints of a recombined mesh's surfaces (those with quads): a hash of each
/// surface's quad blocks, of the coordinates of the nodes they use, and of its node blocks
/// (coordinates, parametric coordinates), with the input's tags and without those the job
/// made (see the module doc); and those made tags in order.
#[derive(Debug, Clone, Default)]
pub(crate) struct Fingerprints(HashMap<i32, (u64, Made)>);

impl Fingerprints {
    /// These fingerprints for a job that optimizes the surfaces `on` accepts with
    /// `variant` (0: the default optimizer options): such a surface an earlier job
    /// optimized with other options is not put back, whatever its recombined state.
    pub(crate) fn with_variant(mut self, variant: u64, on: impl Fn(i32) -> bool) -> Fingerprints {
        if variant != 0 {
            for (_, (f, _)) in self.0.iter_mut().filter(|(s, _)| on(**s)) {
                let mut h = DefaultHasher::new();
                (*f, variant).hash(&mut h);
                *f = h.finish();
            }
        }
        self
    }

    /// The fingerprints of `mesh`'s surfaces; node and element tags above `input_nodes`
    /// and `input_elements` are the job's own.
    pub(crate) fn of(mesh: &Mesh, input_nodes: u64, input_elements: u64) -> Fingerprints {
        let coords = TagCoords::new(mesh);
        let mut state: HashMap<i32, (DefaultHasher, Made)> = HashMap::new();
        let node = |h: &mut DefaultHasher, made: &mut Made, n: u64| {
            if n > input_nodes {
                made.nodes.push(n);
                u64::MAX.hash(h);
            } else {
                n.hash(h);
            }
        };
        for b in mesh.element_blocks.iter().filter(|b| is_quads(b)) {
            let (h, made) = state.entry(b.entity_tag).or_default();
            b.len().hash(h);
            for i in 0..b.len() {
                let t = b.tags[i];
                if t > input_elements {
                    made.elements.push(t);
                    u64::MAX.hash(h);
                } else {
                    t.hash(h);
                }
                for &n in b.element(i) {
                    node(h, made, n);
                    match coords.get(n) {
                        Some(c) => c.iter().for_each(|x| x.to_bits().hash(h)),
                        None => u64::MAX.hash(h),
                    }
                }
            }
        }
        for b in mesh.node_blocks.iter().filter(|b| b.entity_dim == 2) {
            if let Some((h, made)) = state.get_mut(&b.entity_tag) {
                b.tags.len().hash(h);
                for (&t, c) in b.tags.iter().zip(&b.coords) {
                    node(h, made, t);
                    c.iter().for_each(|x| x.to_bits().hash(h));
                }
                if let Some(p) = &b.params {
                    p.iter().for_each(|x| x.to_bits().hash(h));
                }
            }
        }
        Fingerprints(
            state
                .into_iter()
                .map(|(s, (h, made))| (s, (h.finish(), made)))
                .collect(),
        )
    }
}

fn is_quads(b: &ElementBlock) -> bool {
    b.entity_dim == 2 && b.element_type == etype::QUAD4
}

/// One surface's optimized state, and the tags its job made, in the order of
/// [`Made`] in its recombined state.
#[derive(Debug, Clone)]
struct Entry {
    made: Made,
    node_blocks: Vec<NodeBlock>,
    quad_blocks: Vec<ElementBlock>,
    /// The validity check's key (`crate::validity::check_key`) of the output in which
    /// every quad of this state passed the check, if it did.
    passed: Option<crate::validity::CheckKey>,
}

/// The optimized surfaces of earlier jobs (see the module doc).
#[derive(Debug, Clone, Default)]
pub(crate) struct SurfaceCache {
    /// By surface and the fingerprint of its recombined state.
    entries: HashMap<(i32, u64), Entry>,
}

/// `from[i]` → `to[i]`, when that is a map (one image per tag, one tag per image).
fn pairing(from: &[u64], to: &[u64]) -> Option<HashMap<u64, u64>> {
    if from.len() != to.len() {
        return None;
    }
    let mut map = HashMap::with_capacity(from.len());
    let mut back = HashMap::with_capacity(from.len());
    for (&a, &b) in from.iter().zip(to) {
        if *map.entry(a).or_insert(b) != b || *back.entry(b).or_insert(a) != a {
            return None;
        }
    }
    Some(map)
}

impl SurfaceCache {
    /// True when nothing is recorded.
    pub(crate) fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Puts the cached optimized state of every surface of `mesh` (a recombined mesh with
    /// fingerprints `fp`) that an earlier job had in the same recombined state, block for
    /// block in place, with the tags of this job; returns those surfaces, sorted (the
    /// others are left as they are).
    pub(crate) fn put_back(&self, mesh: &mut Mesh, fp: &Fingerprints) -> Vec<i32> {
        let mut done = Vec::new();
        for (&s, (f, made)) in &fp.0 {
            let Some(e) = self.entries.get(&(s, *f)) else {
                continue;
            };
            let (Some(nodes), Some(elements)) = (
                pairing(&e.made.nodes, &made.nodes),
                pairing(&e.made.elements, &made.elements),
            ) else {
                continue;
            };
            let node = |t: u64| nodes.get(&t).copied().unwrap_or(t);
            let node_places: Vec<usize> = (0..mesh.node_blocks.len())
                .filter(|&i| {
                    let b = &mesh.node_blocks[i];
                    b.entity_dim == 2 && b.entity_tag == s
                })
                .collect();
            let quad_places: Vec<usize> = (0..mesh.element_blocks.len())
                .filter(|&i| {
                    is_quads(&mesh.element_blocks[i]) && mesh.element_blocks[i].entity_tag == s
                })
                .collect();
            if node_places.len() != e.node_blocks.len() || quad_places.len() != e.quad_blocks.len()
            {
                continue;
            }
            for (i, b) in node_places.into_iter().zip(&e.node_blocks) {
                let mut b = b.clone();
                b.tags.iter_mut().for_each(|t| *t = node(*t));
                mesh.node_blocks[i] = b;
            }
            for (i, b) in quad_places.into_iter().zip(&e.quad_blocks) {
                let mut b = b.clone();
                b.nodes.iter_mut().for_each(|t| *t = node(*t));
                b.tags
                    .iter_mut()
                    .for_each(|t| *t = elements.get(t).copied().unwrap_or(*t));
                mesh.element_blocks[i] = b;
            }
            done.push(s);
        }
        done.sort_unstable();
        done
    }

    /// Of the surfaces `reused` that [`SurfaceCache::put_back`] gave back with fingerprints
    /// `fp`, those whose state passed the validity check in an output with check key
    /// `key`, sorted: the same quads at the same coordinates pass it again (the validity
    /// check reads no tag the job made, `crate::validity::check_key`).
    pub(crate) fn passed(
        &self,
        fp: &Fingerprints,
        reused: &[i32],
        key: crate::validity::CheckKey,
    ) -> Vec<i32> {
        let mut out: Vec<i32> = reused
            .iter()
            .copied()
            .filter(|s| {
                fp.0.get(s)
                    .and_then(|(f, _)| self.entries.get(&(*s, *f)))
                    .is_some_and(|e| e.passed == Some(key))
            })
            .collect();
        out.sort_unstable();
        out
    }

    /// Records the optimized state of `mesh`'s surfaces, whose recombined state had the
    /// fingerprints `fp`; surfaces that share nodes across blocks (see the module doc) are
    /// not recorded, except through nodes that the quads of both surfaces use (which no
    /// optimizer moves). `passed`: the check key of `mesh` and whether a surface's quads
    /// all passed the validity check in it, when it was checked.
    pub(crate) fn record(
        &mut self,
        mesh: &Mesh,
        fp: &Fingerprints,
        passed: Option<(crate::validity::CheckKey, &dyn Fn(i32) -> bool)>,
    ) {
        // the surface whose node block holds each node
        let mut block_of: HashMap<u64, i32> = HashMap::new();
        for b in mesh.node_blocks.iter().filter(|b| b.entity_dim == 2) {
            for &t in &b.tags {
                block_of.insert(t, b.entity_tag);
            }
        }
        // the nodes of a surface's block that its own quads use: on the boundary between
        // its quads and another surface's that use them too (a split node on a curve
        // without a node block of its own), where neither optimizer moves them
        let mut own_use: HashSet<u64> = HashSet::new();
        for b in mesh.element_blocks.iter().filter(|b| is_quads(b)) {
            for n in &b.nodes {
                if block_of.get(n) == Some(&b.entity_tag) {
                    own_use.insert(*n);
                }
            }
        }
        let mut tangled: HashSet<i32> = HashSet::new();
        for b in &mesh.element_blocks {
            let own = is_quads(b).then_some(b.entity_tag);
            for n in &b.nodes {
                match (block_of.get(n), own) {
                    (Some(&o), Some(s)) if o != s && !own_use.contains(n) => {
                        tangled.insert(o);
                        tangled.insert(s);
                    }
                    (Some(&o), None) if !(b.entity_dim == 2 && b.entity_tag == o) => {
                        tangled.insert(o);
                    }
                    _ => {}
                }
            }
        }
        for (&s, (f, made)) in &fp.0 {
            if tangled.contains(&s) || self.entries.contains_key(&(s, *f)) {
                continue;
            }
            let node_blocks = mesh
                .node_blocks
                .iter()
                .filter(|b| b.entity_dim == 2 && b.entity_tag == s)
                .cloned()
                .collect();
            let quad_blocks = mesh
                .element_blocks
                .iter()
                .filter(|b| is_quads(b) && b.entity_tag == s)
                .cloned()
                .collect();
            self.entries.insert(
                (s, *f),
                Entry {
                    made: made.clone(),
                    node_blocks,
                    quad_blocks,
                    passed: passed.and_then(|(key, ok)| ok(s).then_some(key)),
                },
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimize::{optimize, OptimizeOptions};
    use crate::recombine::{recombine, RecombineOptions};

    /// A thin annulus of two surfaces: the matching makes nodes and elements of its own
    /// (vertex duplications, tags above the input's).
    fn recombined() -> (Mesh, Mesh) {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("fuzz/corpus/pipeline/seed-thin_annulus41.msh");
        let input = crate::msh::read_file(&path).expect("the seed reads");
        let mut mesh = input.clone();
        recombine(&mut mesh, &RecombineOptions::default()).expect("recombines");
        (input, mesh)
    }

    /// `mesh` with every tag above the input's shifted by `by`.
    fn shifted(mesh: &Mesh, nodes: u64, elements: u64, by: u64) -> Mesh {
        let mut m = mesh.clone();
        let node = |t: &mut u64| {
            if *t > nodes {
                *t += by;
            }
        };
        for b in &mut m.node_blocks {
            b.tags.iter_mut().for_each(node);
        }
        for b in &mut m.element_blocks {
            b.nodes.iter_mut().for_each(node);
            b.tags
                .iter_mut()
                .filter(|t| **t > elements)
                .for_each(|t| *t += by);
        }
        m
    }

    #[test]
    fn a_surface_put_back_where_it_passed_the_validity_check_passes_it_again() {
        let (input, mesh) = recombined();
        let (nodes, elements) = (input.max_node_tag(), input.max_element_tag());
        let made = Fingerprints::of(&mesh, nodes, elements);
        let mut optimized = mesh.clone();
        optimize(&mut optimized, &input, &OptimizeOptions::default()).expect("optimizes");
        let reference = crate::validity::Reference::new(&input);
        let bad = reference.invalid_quads(&optimized);
        let bent = crate::validity::Bent::Accepted;
        let key = crate::validity::check_key(&optimized, bent);
        // every surface passed but the first, recorded as not checked
        let first = *made.0.keys().min().expect("a surface");
        let ok = |s: i32| s != first && !bad.iter().any(|b| b.surface == s);
        let mut cache = SurfaceCache::default();
        cache.record(&optimized, &made, Some((key, &ok)));
        // the same recombination with the job's own tags shifted, put back
        let other = shifted(&mesh, nodes, elements, 1000);
        let fp = Fingerprints::of(&other, nodes, elements);
        let mut put = other.clone();
        let reused = cache.put_back(&mut put, &fp);
        assert_eq!(crate::validity::check_key(&put, bent), key);
        let passed = cache.passed(&fp, &reused, key);
        assert!(!passed.is_empty() && !passed.contains(&first), "{passed:?}");
        // the check left out on them finds what the whole check finds
        let all = reference.invalid_quads(&put);
        assert!(all
            .iter()
            .all(|b| passed.binary_search(&b.surface).is_err()));
        let coords = TagCoords::new(&put);
        assert_eq!(
            reference.invalid_quads_except(&put, &coords, &passed, bent),
            all
        );
        // in an output of another check key (another extent, or bent quads judged
        // otherwise), nothing is known to pass
        let mut bigger = put.clone();
        bigger.node_blocks[0].coords[0][0] += 1e3;
        assert!(cache
            .passed(&fp, &reused, crate::validity::check_key(&bigger, bent))
            .is_empty());
        let refused = crate::validity::Bent::Refused;
        assert!(cache
            .passed(&fp, &reused, crate::validity::check_key(&put, refused))
            .is_empty());
    }

    #[test]
    fn a_surface_put_back_is_what_optimizing_it_again_gives_whatever_its_own_tags() {
        let (input, mesh) = recombined();
        let (nodes, elements) = (input.max_node_tag(), input.max_element_tag());
        let made = Fingerprints::of(&mesh, nodes, elements);
        assert!(
            made.0.values().any(|(_, m)| !m.nodes.is_empty()),
            "the recombination made nodes of its own"
        );
        let opts = OptimizeOptions::default();
        let mut optimized = mesh.clone();
        optimize(&mut optimized, &input, &opts).expect("optimizes");
        let mut cache = SurfaceCache::default();
        cache.record(&optimized, &made, None);
        // the same recombination with the job's own tags shifted (as a split elsewhere
        // shifts them): the same fingerprints, and the state put back is the optimizer's
        let other = shifted(&mesh, nodes, elements, 1000);
        let fp = Fingerprints::of(&other, nodes, elements);
        for (s, (f, _)) in &fp.0 {
            assert_eq!(
                made.0[s].0, *f,
                "surface {s}: the fingerprint ignores own tags"
            );
        }
        let mut put = other.clone();
        let surfaces = cache.put_back(&mut put, &fp);
        assert_eq!(surfaces.len(), fp.0.len(), "every surface put back");
        let mut again = other.clone();
        optimize(&mut again, &input, &opts).expect("optimizes");
        assert_eq!(put.node_blocks, again.node_blocks);
        assert_eq!(put.element_blocks, again.element_blocks);
        // the same recombination optimized with other options: nothing put back
        let salted = Fingerprints::of(&other, nodes, elements).with_variant(1, |_| true);
        let mut put = other.clone();
        assert!(cache.put_back(&mut put, &salted).is_empty());
        assert_eq!(put, other);
        let unsalted = Fingerprints::of(&other, nodes, elements).with_variant(0, |_| true);
        assert_eq!(
            cache.put_back(&mut other.clone(), &unsalted).len(),
            fp.0.len()
        );
        // a moved node changes its surface's fingerprint: that surface is not put back
        let mut moved = other.clone();
        let b = moved
            .node_blocks
            .iter_mut()
            .find(|b| b.entity_dim == 2 && !b.coords.is_empty())
            .expect("a surface node");
        b.coords[0][0] += 1e-9;
        let surface = b.entity_tag;
        let fp = Fingerprints::of(&moved, nodes, elements);
        let mut put = moved.clone();
        assert!(!cache.put_back(&mut put, &fp).contains(&surface));
        let block = |m: &Mesh| {
            m.node_blocks
                .iter()
                .find(|b| b.entity_dim == 2 && b.entity_tag == surface)
                .cloned()
        };
        assert_eq!(block(&put), block(&moved));
    }

    #[test]
    fn a_node_both_surfaces_quads_use_in_one_surfaces_block_keeps_both_reusable() {
        // a node on the curve between the two surfaces moved into the first surface's block
        // (where a fallback split of a curve with no node block of its own puts its node):
        // both surfaces are still recorded, and what is put back is the optimizer's; a node
        // of that block that only the other surface's quads use keeps both out
        let (input, mut mesh) = recombined();
        let (nodes, elements) = (input.max_node_tag(), input.max_element_tag());
        let users = |m: &Mesh, t: u64| -> Vec<i32> {
            let mut s: Vec<i32> = m
                .element_blocks
                .iter()
                .filter(|b| is_quads(b) && b.nodes.contains(&t))
                .map(|b| b.entity_tag)
                .collect();
            s.sort_unstable();
            s.dedup();
            s
        };
        let (ci, k) = mesh
            .node_blocks
            .iter()
            .enumerate()
            .filter(|(_, b)| b.entity_dim == 1)
            .find_map(|(i, b)| {
                (0..b.tags.len())
                    .find(|&k| users(&mesh, b.tags[k]).len() == 2)
                    .map(|k| (i, k))
            })
            .expect("a curve node both surfaces' quads use");
        let tag = mesh.node_blocks[ci].tags.remove(k);
        let c = mesh.node_blocks[ci].coords.remove(k);
        let (owner, user) = (users(&mesh, tag)[0], users(&mesh, tag)[1]);
        let b = mesh
            .node_blocks
            .iter_mut()
            .find(|b| b.entity_dim == 2 && b.entity_tag == owner)
            .expect("the surface's block");
        b.tags.push(tag);
        b.coords.push(c);
        let opts = OptimizeOptions::default();
        let made = Fingerprints::of(&mesh, nodes, elements);
        let mut optimized = mesh.clone();
        optimize(&mut optimized, &input, &opts).expect("optimizes");
        let mut cache = SurfaceCache::default();
        cache.record(&optimized, &made, None);
        assert_eq!(cache.entries.len(), made.0.len(), "every surface recorded");
        let other = shifted(&mesh, nodes, elements, 1000);
        let fp = Fingerprints::of(&other, nodes, elements);
        let mut put = other.clone();
        assert_eq!(cache.put_back(&mut put, &fp).len(), fp.0.len());
        let mut again = other.clone();
        optimize(&mut again, &input, &opts).expect("optimizes");
        assert_eq!(put.node_blocks, again.node_blocks);
        assert_eq!(put.element_blocks, again.element_blocks);
        // the node used by the other surface's quads alone: neither is recorded
        let mut alone = optimized.clone();
        for b in alone
            .element_blocks
            .iter_mut()
            .filter(|b| b.entity_tag == owner)
        {
            b.nodes
                .iter_mut()
                .filter(|t| **t == tag)
                .for_each(|t| *t = u64::MAX);
        }
        let mut cache = SurfaceCache::default();
        cache.record(&alone, &made, None);
        assert!(!cache.entries.keys().any(|k| k.0 == owner || k.0 == user));
    }
}
