//! Closest-point queries on a triangulated surface: the reference triangulation that sizes
//! are interpolated on (τ, eq. 1) and that smoothed nodes are projected back onto.
//!
//! Two queries: [`TriSurface::closest`] searches a uniform grid of triangle buckets (any
//! point, no prior knowledge), [`TriSurface::walk`] starts from a known triangle and walks
//! across edges towards the point (a node that moved a fraction of an edge needs one or two
//! steps). Both return the triangle, the closest point on it and its barycentric coordinates.
//! [`TriSurface::near`] lists every triangle within a distance of a point, joined to the
//! others or not (where a surface lies over itself, both layers).
//!
//! **Invariant:** indices only; the structure never looks at mesh tags.

use glam::DVec3;
use rayon::slice::ParallelSliceMut;

/// Sentinel for "no neighbour" in [`TriSurface`] adjacency (the crate's one sentinel).
pub(crate) use crate::mesh::NONE;

/// Result of a closest-point query.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Index of the triangle the closest point lies on.
    pub tri: u32,
    /// The closest point.
    pub point: DVec3,
    /// Barycentric coordinates of `point` in the triangle (sum 1, each in [0, 1]).
    pub bary: [f64; 3],
}

/// A triangle soup with edge adjacency and a uniform bucket grid.
#[derive(Debug, Clone)]
pub struct TriSurface {
    points: Vec<DVec3>,
    tris: Vec<[u32; 3]>,
    /// `nbr[t][k]`: triangle across the edge opposite vertex `k` of `t`, or [`NONE`]
    /// (boundary or non-manifold edge).
    nbr: Vec<[u32; 3]>,
    grid: Grid,
    /// Each triangle's [`Frame`], built on the first [`TriSurface::walk`] (speed: a walk
    /// step reads one frame instead of three corners, and computes two dot products
    /// instead of five; memory: only surfaces that are walked on pay for them).
    frames: std::sync::OnceLock<Vec<Frame>>,
}

/// A triangle `a b c` as [`plane_barycentric`] reads it: the corner `a`, the edges
/// `e0 = b - a` and `e1 = c - a`, their dot products and the determinant `den` (the same
/// values in the same order of operations, so the coordinates come out bit for bit the
/// same).
#[derive(Debug, Clone)]
struct Frame {
    a: DVec3,
    e0: DVec3,
    e1: DVec3,
    d00: f64,
    d01: f64,
    d11: f64,
    den: f64,
}

impl Frame {
    fn new([a, b, c]: [DVec3; 3]) -> Frame {
        let e0 = b - a;
        let e1 = c - a;
        let d00 = e0.dot(e0);
        let d01 = e0.dot(e1);
        let d11 = e1.dot(e1);
        Frame {
            a,
            e0,
            e1,
            d00,
            d01,
            d11,
            den: d00 * d11 - d01 * d01,
        }
    }

    /// [`plane_barycentric`] of `p` in this triangle.
    fn barycentric(&self, p: DVec3) -> [f64; 3] {
        let w = p - self.a;
        let d20 = w.dot(self.e0);
        let d21 = w.dot(self.e1);
        let (d00, d01, d11, den) = (self.d00, self.d01, self.d11, self.den);
        if den.abs() <= f64::EPSILON * d00 * d11 || den == 0.0 {
            return [1.0, 0.0, 0.0];
        }
        let v = (d11 * d20 - d01 * d21) / den;
        let w2 = (d00 * d21 - d01 * d20) / den;
        [1.0 - v - w2, v, w2]
    }
}

#[derive(Debug, Clone)]
struct Grid {
    origin: DVec3,
    cell: f64,
    dims: [usize; 3],
    start: Vec<u32>,
    items: Vec<u32>,
}

impl TriSurface {
    /// Builds the adjacency and the grid. Triangles referring to a point index out of range
    /// are dropped (callers build indices themselves, so this only guards against misuse).
    pub fn new(points: Vec<DVec3>, tris: Vec<[u32; 3]>) -> Self {
        let n = points.len();
        let tris: Vec<[u32; 3]> = tris
            .into_iter()
            .filter(|t| t.iter().all(|&v| (v as usize) < n))
            .collect();
        let nbr = triangle_neighbours(&tris);
        let grid = Grid::new(&points, &tris);
        TriSurface {
            points,
            tris,
            nbr,
            grid,
            frames: std::sync::OnceLock::new(),
        }
    }

    /// Number of triangles.
    #[cfg(any(test, feature = "testing"))]
    pub fn len(&self) -> usize {
        self.tris.len()
    }

    /// True when there is no triangle.
    #[cfg(any(test, feature = "testing"))]
    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    /// Point indices of triangle `t`.
    pub fn triangle(&self, t: u32) -> [u32; 3] {
        self.tris[t as usize]
    }

    /// Unit normal of triangle `t` (zero for a degenerate triangle), oriented by its vertex
    /// order.
    pub fn normal(&self, t: u32) -> DVec3 {
        let [a, b, c] = self.corners(t);
        (b - a).cross(c - a).normalize_or_zero()
    }

    fn corners(&self, t: u32) -> [DVec3; 3] {
        let [a, b, c] = self.tris[t as usize];
        [
            self.points[a as usize],
            self.points[b as usize],
            self.points[c as usize],
        ]
    }

    /// Adds to `out` the triangles that point `p` of triangle `t` touches within `tol`:
    /// `t`, the neighbour across each edge of `t` within `tol` of `p`, and every triangle
    /// around each corner of `t` within `tol` of `p` (as far as edge neighbours reach from
    /// `t` both ways around it). Each triangle once; `out` is not cleared.
    pub fn touching(&self, t: u32, p: DVec3, tol: f64, out: &mut Vec<u32>) {
        let push = |out: &mut Vec<u32>, x: u32| {
            if x != NONE && !out.contains(&x) {
                out.push(x);
            }
        };
        push(out, t);
        let c = self.corners(t);
        for k in 0..3 {
            // the edge opposite corner k
            let (a, b) = (c[(k + 1) % 3], c[(k + 2) % 3]);
            if closest_on_segment(p, a, b).distance(p) <= tol {
                push(out, self.nbr[t as usize][k]);
            }
        }
        for (k, corner) in c.iter().enumerate() {
            if corner.distance(p) > tol {
                continue;
            }
            let x = self.tris[t as usize][k];
            // around corner x: cross the edges at x, one way then the other
            for first in [(k + 1) % 3, (k + 2) % 3] {
                let (mut cur, mut across) = (t, first);
                for _ in 0..64 {
                    let next = self.nbr[cur as usize][across];
                    if next == NONE || next == t {
                        break;
                    }
                    push(out, next);
                    let tri = self.tris[next as usize];
                    let Some(at) = tri.iter().position(|&v| v == x) else {
                        break;
                    };
                    // the other edge at x of `next`: opposite the corner that is neither x
                    // nor on the edge crossed
                    let Some(back) = (0..3).find(|&j| j != at && self.nbr[next as usize][j] == cur)
                    else {
                        break;
                    };
                    across = 3 - at - back;
                    cur = next;
                }
            }
        }
    }

    /// Adds to `out` every triangle whose bounding box comes within `r` of `p`, each once
    /// (sorted): a superset of the triangles within distance `r` of `p`, wherever they are
    /// on the surface, joined to each other or not. `out` is cleared first.
    pub fn near(&self, p: DVec3, r: f64, out: &mut Vec<u32>) {
        out.clear();
        let g = &self.grid;
        if self.tris.is_empty() || r.is_nan() {
            return;
        }
        let (a, b) = (g.cell_of(p - DVec3::splat(r)), g.cell_of(p + DVec3::splat(r)));
        g.each_cell(a, b, |i| {
            for &t in &g.items[g.start[i] as usize..g.start[i + 1] as usize] {
                let (lo, hi) = corner_box(self.corners(t));
                let gap = (lo - p).max(p - hi).max(DVec3::ZERO);
                if gap.length() <= r {
                    out.push(t);
                }
            }
        });
        out.sort_unstable();
        out.dedup();
    }

    /// Closest point on the whole surface, or `None` when there is no triangle.
    pub fn closest(&self, p: DVec3) -> Option<Hit> {
        if self.tris.is_empty() {
            return None;
        }
        let g = &self.grid;
        let c = g.cell_of(p);
        let mut best: Option<(f64, Hit)> = None;
        let max_r = g.dims.iter().copied().max().unwrap_or(1);
        for r in 0..=max_r {
            g.for_ring(c, r, |t| {
                let corners = self.corners(t);
                // speed: a triangle whose bounding box is farther than the best point so far
                // cannot be nearer (a margin above rounding keeps ties computed)
                if let Some((bd, _)) = best {
                    let (lo, hi) = corner_box(corners);
                    let gap = (lo - p).max(p - hi).max(DVec3::ZERO);
                    if gap.length_squared() > bd * (1.0 + 1e-9) {
                        return;
                    }
                }
                let (q, bary) = closest_on_triangle(p, corners);
                let d = q.distance_squared(p);
                if best.is_none_or(|(bd, _)| d < bd) {
                    best = Some((
                        d,
                        Hit {
                            tri: t,
                            point: q,
                            bary,
                        },
                    ));
                }
            });
            let reach = g.unvisited_distance(p, c, r);
            if let Some((d, _)) = best {
                if d <= reach * reach {
                    break;
                }
            }
            if reach == f64::INFINITY {
                break;
            }
        }
        best.map(|(_, h)| h)
    }

    /// Closest point found by walking from triangle `start` towards `p` across edges; falls
    /// back to [`TriSurface::closest`] when the walk does not settle.
    pub fn walk(&self, start: u32, p: DVec3) -> Option<Hit> {
        if start as usize >= self.tris.len() {
            return self.closest(p);
        }
        let frames = self
            .frames
            .get_or_init(|| (0..self.tris.len() as u32).map(|t| Frame::new(self.corners(t))).collect());
        let mut t = start;
        let mut prev = NONE;
        for _ in 0..48 {
            let bary = frames[t as usize].barycentric(p);
            if bary.iter().all(|&b| b >= -1e-12) {
                // speed: the coordinates found are not computed again
                let (q, bary) = closest_with_barycentric(p, self.corners(t), bary);
                return Some(Hit {
                    tri: t,
                    point: q,
                    bary,
                });
            }
            // cross the edge of the most negative coordinate that leads somewhere new
            let order = ascending3(bary);
            let next = order
                .iter()
                .filter(|&&k| bary[k] < -1e-12)
                .map(|&k| self.nbr[t as usize][k])
                .find(|&n| n != NONE && n != prev);
            match next {
                Some(n) => {
                    prev = t;
                    t = n;
                }
                None => break,
            }
        }
        self.closest(p)
    }
}

/// The indices of `x` by increasing value, ties in index order (a stable sort of three).
fn ascending3(x: [f64; 3]) -> [usize; 3] {
    let mut o = [0usize, 1, 2];
    let gt = |o: &[usize; 3], i: usize, j: usize| x[o[i]].total_cmp(&x[o[j]]).is_gt();
    if gt(&o, 0, 1) {
        o.swap(0, 1);
    }
    if gt(&o, 1, 2) {
        o.swap(1, 2);
        if gt(&o, 0, 1) {
            o.swap(0, 1);
        }
    }
    o
}

/// Neighbour across each edge; edges used by other than exactly two triangles have none.
fn triangle_neighbours(tris: &[[u32; 3]]) -> Vec<[u32; 3]> {
    let mut half: Vec<(u32, u32, u32)> = Vec::with_capacity(tris.len() * 3);
    for (t, tri) in tris.iter().enumerate() {
        for k in 0..3 {
            let a = tri[(k + 1) % 3];
            let b = tri[(k + 2) % 3];
            half.push((a.min(b), a.max(b), (t as u32) * 3 + k as u32));
        }
    }
    half.par_sort_unstable();
    let mut nbr = vec![[NONE; 3]; tris.len()];
    let mut i = 0;
    while i < half.len() {
        let mut j = i + 1;
        while j < half.len() && half[j].0 == half[i].0 && half[j].1 == half[i].1 {
            j += 1;
        }
        if j - i == 2 {
            let (x, y) = (half[i].2, half[i + 1].2);
            nbr[(x / 3) as usize][(x % 3) as usize] = y / 3;
            nbr[(y / 3) as usize][(y % 3) as usize] = x / 3;
        }
        i = j;
    }
    nbr
}

impl Grid {
    fn new(points: &[DVec3], tris: &[[u32; 3]]) -> Self {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        let mut diag_sum = 0.0;
        for t in tris {
            let (a, b) = tri_box(points, t);
            lo = lo.min(a);
            hi = hi.max(b);
            diag_sum += (b - a).length();
        }
        if tris.is_empty() {
            return Grid {
                origin: DVec3::ZERO,
                cell: 1.0,
                dims: [1, 1, 1],
                start: vec![0, 0],
                items: Vec::new(),
            };
        }
        let ext = hi - lo;
        let mut cell = (diag_sum / tris.len() as f64).max(ext.max_element() * 1e-6);
        if cell.is_nan() || cell <= 0.0 || !cell.is_finite() {
            cell = 1.0;
        }
        // Cap the cell count at a few per triangle. Cells per axis are counted in floating
        // point and clamped before the cast (an extent that overflows or dwarfs the cell,
        // e.g. coordinates near 1e306, must not overflow the integer arithmetic), and the
        // product saturates.
        let cap = 4 * tris.len() + 64;
        let dims_for = |c: f64| {
            [0, 1, 2].map(|i| {
                let n = (ext[i] / c).floor();
                if n.is_nan() || n <= 0.0 {
                    1
                } else {
                    // +∞ clamps to the cap too
                    (n.min(cap as f64) as usize).saturating_add(1)
                }
            })
        };
        let count_of = |d: [usize; 3]| d[0].saturating_mul(d[1]).saturating_mul(d[2]);
        let mut dims = dims_for(cell);
        while count_of(dims) > cap {
            cell *= 1.5;
            dims = dims_for(cell);
        }
        let mut g = Grid {
            origin: lo,
            cell,
            dims,
            start: Vec::new(),
            items: Vec::new(),
        };
        let ncell = dims[0] * dims[1] * dims[2];
        let mut count = vec![0u32; ncell + 1];
        let ranges: Vec<([usize; 3], [usize; 3])> = tris
            .iter()
            .map(|t| {
                let (a, b) = tri_box(points, t);
                (g.cell_of(a), g.cell_of(b))
            })
            .collect();
        for (a, b) in &ranges {
            g.each_cell(*a, *b, |c| count[c + 1] += 1);
        }
        for i in 0..ncell {
            count[i + 1] += count[i];
        }
        let mut fill = count.clone();
        let mut items = vec![0u32; count[ncell] as usize];
        for (t, (a, b)) in ranges.iter().enumerate() {
            g.each_cell(*a, *b, |c| {
                items[fill[c] as usize] = t as u32;
                fill[c] += 1;
            });
        }
        g.start = count;
        g.items = items;
        g
    }

    fn cell_of(&self, p: DVec3) -> [usize; 3] {
        [0, 1, 2].map(|i| {
            let f = ((p[i] - self.origin[i]) / self.cell).floor();
            if f.is_nan() || f < 0.0 {
                0
            } else {
                (f as usize).min(self.dims[i] - 1)
            }
        })
    }

    /// Lower bound of the distance from `p` (in cell `c`) to any cell outside the cube of
    /// cells at Chebyshev distance ≤ `r` from `c`; infinite when that cube covers the grid.
    fn unvisited_distance(&self, p: DVec3, c: [usize; 3], r: usize) -> f64 {
        let mut d = f64::INFINITY;
        for i in 0..3 {
            if c[i] > r {
                let face = self.origin[i] + (c[i] - r) as f64 * self.cell;
                d = d.min((p[i] - face).max(0.0));
            }
            if c[i] + r + 1 < self.dims[i] {
                let face = self.origin[i] + (c[i] + r + 1) as f64 * self.cell;
                d = d.min((face - p[i]).max(0.0));
            }
        }
        d
    }

    fn index(&self, c: [usize; 3]) -> usize {
        (c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]
    }

    fn each_cell(&self, a: [usize; 3], b: [usize; 3], mut f: impl FnMut(usize)) {
        for z in a[2]..=b[2] {
            for y in a[1]..=b[1] {
                for x in a[0]..=b[0] {
                    f(self.index([x, y, z]));
                }
            }
        }
    }

    /// Calls `f` for every triangle of the cells at Chebyshev distance exactly `r` from `c`
    /// (a triangle spanning several cells may be visited more than once).
    fn for_ring(&self, c: [usize; 3], r: usize, mut f: impl FnMut(u32)) {
        let lo = c.map(|v| v as isize - r as isize);
        let hi = c.map(|v| v as isize + r as isize);
        for z in lo[2].max(0)..=hi[2].min(self.dims[2] as isize - 1) {
            for y in lo[1].max(0)..=hi[1].min(self.dims[1] as isize - 1) {
                let on_yz = z == lo[2] || z == hi[2] || y == lo[1] || y == hi[1];
                let mut x = lo[0].max(0);
                let xe = hi[0].min(self.dims[0] as isize - 1);
                while x <= xe {
                    if on_yz || x == lo[0] || x == hi[0] {
                        let i = self.index([x as usize, y as usize, z as usize]);
                        for &t in &self.items[self.start[i] as usize..self.start[i + 1] as usize] {
                            f(t);
                        }
                        x += 1;
                    } else {
                        // skip the interior of the ring row
                        x = hi[0];
                    }
                }
            }
        }
    }
}

fn tri_box(points: &[DVec3], t: &[u32; 3]) -> (DVec3, DVec3) {
    corner_box(t.map(|v| points[v as usize]))
}

/// The bounding box (lowest, highest corner) of a triangle's corners.
fn corner_box([a, b, c]: [DVec3; 3]) -> (DVec3, DVec3) {
    (a.min(b).min(c), a.max(b).max(c))
}

/// Barycentric coordinates of the projection of `p` onto the plane of the triangle
/// (unclamped: negative outside). A degenerate triangle gives `[1, 0, 0]`.
pub fn plane_barycentric(p: DVec3, t: [DVec3; 3]) -> [f64; 3] {
    Frame::new(t).barycentric(p)
}

/// Closest point of segment `ab` to `p` (`a` when the segment has no length).
pub fn closest_on_segment(p: DVec3, a: DVec3, b: DVec3) -> DVec3 {
    let e = b - a;
    let len2 = e.length_squared();
    let s = if len2 > 0.0 {
        ((p - a).dot(e) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    a + e * s
}

/// Closest point of triangle `[a, b, c]` to `p`, with its barycentric coordinates.
pub fn closest_on_triangle(p: DVec3, t: [DVec3; 3]) -> (DVec3, [f64; 3]) {
    closest_with_barycentric(p, t, plane_barycentric(p, t))
}

/// [`closest_on_triangle`] given `bary`, the [`plane_barycentric`] coordinates of `p`.
fn closest_with_barycentric(p: DVec3, t: [DVec3; 3], bary: [f64; 3]) -> (DVec3, [f64; 3]) {
    if bary.iter().all(|&x| x >= 0.0) {
        return (t[0] * bary[0] + t[1] * bary[1] + t[2] * bary[2], bary);
    }
    // Outside: the closest point is on one of the three edges.
    let mut best = (f64::INFINITY, DVec3::ZERO, [1.0, 0.0, 0.0]);
    for k in 0..3 {
        let (i, j) = (k, (k + 1) % 3);
        let e = t[j] - t[i];
        let len2 = e.length_squared();
        let s = if len2 > 0.0 {
            ((p - t[i]).dot(e) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let q = t[i] + e * s;
        let d = q.distance_squared(p);
        if d < best.0 {
            let mut b = [0.0; 3];
            b[i] = 1.0 - s;
            b[j] = s;
            best = (d, q, b);
        }
    }
    (best.1, best.2)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid_surface(n: usize) -> TriSurface {
        let mut pts = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                pts.push(DVec3::new(i as f64, j as f64, 0.0));
            }
        }
        let id = |i: usize, j: usize| (j * (n + 1) + i) as u32;
        let mut tris = Vec::new();
        for j in 0..n {
            for i in 0..n {
                tris.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                tris.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        TriSurface::new(pts, tris)
    }

    #[test]
    fn a_point_touches_its_triangle_the_neighbours_across_its_edge_and_around_its_corner() {
        let s = grid_surface(4);
        let touching = |p: DVec3, tol: f64| {
            let hit = s.closest(p).expect("a triangle");
            let mut out = Vec::new();
            s.touching(hit.tri, hit.point, tol, &mut out);
            out.sort_unstable();
            out
        };
        // inside a triangle: that one
        assert_eq!(touching(DVec3::new(1.7, 1.2, 0.0), 1e-9).len(), 1);
        // on an edge between two triangles (a diagonal, then a grid line): both
        assert_eq!(touching(DVec3::new(1.5, 1.5, 0.0), 1e-9).len(), 2);
        assert_eq!(touching(DVec3::new(1.5, 2.0, 0.0), 1e-9).len(), 2);
        // within the tolerance of the edge, not on it: both; farther: one
        assert_eq!(touching(DVec3::new(1.5, 2.0 - 1e-7, 0.0), 1e-6).len(), 2);
        assert_eq!(touching(DVec3::new(1.5, 2.0 - 1e-3, 0.0), 1e-6).len(), 1);
        // on an inner corner: the six triangles around it, whichever one is hit
        for p in [DVec3::new(2.0, 2.0, 0.0), DVec3::new(2.0 + 1e-12, 2.0, 0.0)] {
            let got = touching(p, 1e-9);
            assert_eq!(got.len(), 6, "{p}: {got:?}");
            for t in got {
                assert!(s.triangle(t).contains(&(2 * 5 + 2)), "{t}");
            }
        }
        // on a boundary corner: the two triangles there
        assert_eq!(touching(DVec3::new(0.0, 0.0, 0.0), 1e-9).len(), 2);
        assert_eq!(touching(DVec3::new(4.0, 0.0, 0.0), 1e-9).len(), 1);
        assert_eq!(touching(DVec3::new(2.0, 0.0, 0.0), 1e-9).len(), 3);
    }

    #[test]
    fn near_finds_every_triangle_within_reach_joined_or_not() {
        // a grid in z = 0 and one triangle lying over it, 1e-3 above, joined to nothing
        let mut s = grid_surface(6);
        let (mut points, mut tris) = (s.points.clone(), s.tris.clone());
        let first = points.len() as u32;
        points.extend([
            DVec3::new(0.3, 0.3, 1e-3),
            DVec3::new(0.5, 0.3, 1e-3),
            DVec3::new(0.3, 0.5, 1e-3),
        ]);
        tris.push([first, first + 1, first + 2]);
        s = TriSurface::new(points, tris);
        let p = DVec3::new(0.35, 0.35, 0.0);
        let mut out = Vec::new();
        s.near(p, 2e-3, &mut out);
        let corners = |t: u32| s.corners(t);
        let within: Vec<u32> = (0..s.tris.len() as u32)
            .filter(|&t| closest_on_triangle(p, corners(t)).0.distance(p) <= 2e-3)
            .collect();
        assert!(within.contains(&(s.tris.len() as u32 - 1)), "{within:?}");
        assert!(within.iter().all(|t| out.contains(t)), "{within:?} in {out:?}");
        assert!(out.windows(2).all(|w| w[0] < w[1]), "sorted, each once: {out:?}");
        // beneath the loose triangle's reach, only the grid's
        s.near(p, 5e-4, &mut out);
        assert!(!out.contains(&(s.tris.len() as u32 - 1)), "{out:?}");
        assert!(!out.is_empty());
    }

    #[test]
    fn three_values_sort_as_a_stable_sort_does() {
        let vals = [-1.0, 0.0, 1.0, f64::NAN, -0.0];
        for &a in &vals {
            for &b in &vals {
                for &c in &vals {
                    let x = [a, b, c];
                    let mut want = [0usize, 1, 2];
                    want.sort_by(|&i, &j| x[i].total_cmp(&x[j]));
                    assert_eq!(ascending3(x), want, "{x:?}");
                }
            }
        }
    }

    #[test]
    fn closest_and_walk_agree_on_a_plane() {
        let s = grid_surface(10);
        for &(x, y, z) in &[
            (3.3, 4.7, 1.0),
            (0.1, 9.9, -2.0),
            (12.0, 5.5, 0.0),
            (-1.0, -1.0, 0.5),
        ] {
            let p = DVec3::new(x, y, z);
            let expect = DVec3::new(x.clamp(0.0, 10.0), y.clamp(0.0, 10.0), 0.0);
            let h = s.closest(p).unwrap();
            assert!(h.point.distance(expect) < 1e-9, "{p} -> {}", h.point);
            let w = s.walk(0, p).unwrap();
            assert!(w.point.distance(expect) < 1e-9, "walk {p} -> {}", w.point);
            let sum: f64 = h.bary.iter().sum();
            assert!((sum - 1.0).abs() < 1e-12);
        }
    }

    /// Fuzzing found `attempt to add with overflow` in the grid's cell count when the
    /// coordinates span ~1e306 (the extent overflows to infinity): building and querying
    /// must neither overflow nor loop.
    #[test]
    fn huge_and_overflowing_extents_build_a_grid() {
        for big in [1e17, 1e154, 1e306, f64::MAX] {
            let pts = vec![
                DVec3::new(-big, 0.0, 0.0),
                DVec3::new(big, 0.0, 0.0),
                DVec3::new(0.0, big, 0.0),
                DVec3::new(0.0, 1.0, 0.0),
                DVec3::new(1.0, 1.0, 0.0),
            ];
            let s = TriSurface::new(pts, vec![[0, 1, 2], [0, 3, 4]]);
            assert!(s.grid.dims.iter().all(|&d| d >= 1));
            assert!(s.grid.dims.iter().product::<usize>() <= 4 * 2 + 64);
            // a query answers (any triangle) or not, without a panic
            let _ = s.closest(DVec3::new(0.5, 0.5, 0.0));
        }
    }
}
