//! An aggregation multigrid preconditioner for the conformal solve's Hermitian system
//! (`conformal`): levels by grouping each node with its free neighbours
//! ([`aggregate_with`]; piecewise-constant prolongation, Galerkin coarse matrices `Pᴴ A P`
//! in compressed rows of complex entries), one damped Jacobi sweep before and after the
//! coarse correction, and a dense Cholesky factorization on the coarsest level. The finest
//! level is `conformal`'s own (its matrix is the quads' product, never stored); a
//! [`Multigrid`] holds the levels from the first coarse matrix down. The V-cycle is
//! symmetric, so it preconditions conjugate gradients.
//!
//! **Invariant:** every sum runs in a fixed order (rows in parallel, each row's entries in
//! column order), so the result does not depend on the thread count.

use rayon::prelude::*;

/// A complex number (re, im) in single precision.
pub(super) type Cx = [f32; 2];

#[inline]
fn mul(a: Cx, b: Cx) -> Cx {
    [a[0] * b[0] - a[1] * b[1], a[0] * b[1] + a[1] * b[0]]
}

#[inline]
fn add(a: Cx, b: Cx) -> Cx {
    [a[0] + b[0], a[1] + b[1]]
}

#[inline]
fn sub(a: Cx, b: Cx) -> Cx {
    [a[0] - b[0], a[1] - b[1]]
}

#[inline]
fn scale(a: Cx, s: f32) -> Cx {
    [a[0] * s, a[1] * s]
}

/// A square complex matrix in compressed rows, each row's columns increasing.
pub(super) struct Csr {
    pub start: Vec<u32>,
    pub col: Vec<u32>,
    pub val: Vec<Cx>,
}

impl Csr {
    fn rows(&self) -> usize {
        self.start.len() - 1
    }

    /// `out = A x`, rows in parallel.
    fn apply(&self, x: &[Cx], out: &mut [Cx]) {
        out.par_iter_mut()
            .with_min_len(2048)
            .enumerate()
            .for_each(|(i, o)| {
                let mut s = [0.0f32; 2];
                for e in self.start[i] as usize..self.start[i + 1] as usize {
                    s = add(s, mul(self.val[e], x[self.col[e] as usize]));
                }
                *o = s;
            });
    }

    /// The real diagonal of each row (0 when missing).
    fn diagonal(&self) -> Vec<f32> {
        (0..self.rows())
            .map(|i| {
                let range = self.start[i] as usize..self.start[i + 1] as usize;
                range
                    .clone()
                    .find(|&e| self.col[e] as usize == i)
                    .map_or(0.0, |e| self.val[e][0])
            })
            .collect()
    }
}

/// One level above the coarsest: its matrix, inverse diagonal and aggregates.
struct Level {
    a: Csr,
    inv_diag: Vec<f32>,
    /// Aggregate (coarse node) of each node.
    agg: Vec<u32>,
    /// The nodes of each aggregate, in compressed rows.
    members_start: Vec<u32>,
    members: Vec<u32>,
}

/// The preconditioner: the levels, and the coarsest level's Cholesky factor.
pub(super) struct Multigrid {
    levels: Vec<Level>,
    /// Lower triangular factor of the coarsest matrix, row-major `n × n` (f64).
    chol: Vec<[f64; 2]>,
    coarse_n: usize,
}

/// Damping of the Jacobi sweeps (the finest level's too).
pub(super) const OMEGA: f32 = 0.6;

/// Levels stop at this many nodes (or when a level does not halve), where the dense
/// factorization takes over.
const COARSEST: usize = 400;

impl Multigrid {
    /// The hierarchy of the Hermitian positive definite matrix `a`.
    pub(super) fn new(a: Csr) -> Self {
        let mut levels = Vec::new();
        let mut a = a;
        while a.rows() > COARSEST {
            let (agg, count) = aggregate(&a);
            if 2 * count > a.rows() {
                break;
            }
            let (members_start, members) = members_of(&agg, count);
            let coarse = galerkin(&a, &agg, &members_start, &members, count);
            let inv_diag = a
                .diagonal()
                .iter()
                .map(|&d| if d > 0.0 { 1.0 / d } else { 0.0 })
                .collect();
            levels.push(Level {
                a,
                inv_diag,
                agg,
                members_start,
                members,
            });
            a = coarse;
        }
        let coarse_n = a.rows();
        let chol = cholesky(&a);
        Multigrid {
            levels,
            chol,
            coarse_n,
        }
    }

    /// `z ≈ A⁻¹ r`: one V-cycle from zero.
    pub(super) fn precondition(&self, r: &[Cx], z: &mut [Cx]) {
        self.cycle(0, r, z);
    }

    fn cycle(&self, k: usize, b: &[Cx], x: &mut [Cx]) {
        let Some(level) = self.levels.get(k) else {
            self.coarse_solve(b, x);
            return;
        };
        let n = level.a.rows();
        // pre-smoothing from zero
        x.par_iter_mut()
            .with_min_len(4096)
            .zip(b.par_iter().zip(&level.inv_diag))
            .for_each(|(x, (b, &d))| *x = scale(*b, OMEGA * d));
        let mut res = vec![[0.0f32; 2]; n];
        level.a.apply(x, &mut res);
        res.par_iter_mut()
            .with_min_len(4096)
            .zip(b.par_iter())
            .for_each(|(r, b)| *r = sub(*b, *r));
        // restriction: the sum over each aggregate
        let nc = level.members_start.len() - 1;
        let rc: Vec<Cx> = (0..nc)
            .into_par_iter()
            .with_min_len(1024)
            .map(|c| {
                let range = level.members_start[c] as usize..level.members_start[c + 1] as usize;
                level.members[range]
                    .iter()
                    .fold([0.0f32; 2], |s, &i| add(s, res[i as usize]))
            })
            .collect();
        let mut xc = vec![[0.0f32; 2]; nc];
        self.cycle(k + 1, &rc, &mut xc);
        // prolongation, then post-smoothing
        x.par_iter_mut()
            .with_min_len(4096)
            .zip(level.agg.par_iter())
            .for_each(|(x, &c)| *x = add(*x, xc[c as usize]));
        level.a.apply(x, &mut res);
        x.par_iter_mut()
            .with_min_len(4096)
            .zip(b.par_iter().zip(res.par_iter().zip(&level.inv_diag)))
            .for_each(|(x, (b, (ax, &d)))| *x = add(*x, scale(sub(*b, *ax), OMEGA * d)));
    }

    /// `x = A⁻¹ b` on the coarsest level, by the Cholesky factor.
    fn coarse_solve(&self, b: &[Cx], x: &mut [Cx]) {
        let n = self.coarse_n;
        let l = |i: usize, j: usize| self.chol[i * n + j];
        let cmul = |a: [f64; 2], b: [f64; 2]| [a[0] * b[0] - a[1] * b[1], a[0] * b[1] + a[1] * b[0]];
        let conj = |a: [f64; 2]| [a[0], -a[1]];
        // L y = b
        let mut y = vec![[0.0f64; 2]; n];
        for i in 0..n {
            let mut s = [f64::from(b[i][0]), f64::from(b[i][1])];
            for (j, &yj) in y.iter().enumerate().take(i) {
                let p = cmul(l(i, j), yj);
                s = [s[0] - p[0], s[1] - p[1]];
            }
            let d = l(i, i)[0];
            y[i] = if d > 0.0 { [s[0] / d, s[1] / d] } else { [0.0; 2] };
        }
        // Lᴴ x = y
        for i in (0..n).rev() {
            let mut s = y[i];
            for (j, &yj) in y.iter().enumerate().skip(i + 1) {
                let p = cmul(conj(l(j, i)), yj);
                s = [s[0] - p[0], s[1] - p[1]];
            }
            let d = l(i, i)[0];
            y[i] = if d > 0.0 { [s[0] / d, s[1] / d] } else { [0.0; 2] };
        }
        for (x, y) in x.iter_mut().zip(&y) {
            *x = [y[0] as f32, y[1] as f32];
        }
    }
}

/// Groups the nodes of `a` ([`aggregate_with`] with its off-diagonal entries as neighbours).
fn aggregate(a: &Csr) -> (Vec<u32>, usize) {
    aggregate_with(
        a.rows(),
        |i| {
            a.col[a.start[i] as usize..a.start[i + 1] as usize]
                .iter()
                .map(|&j| j as usize)
                .filter(move |&j| j != i)
        },
        |_| true,
    )
}

/// Groups the `n` nodes for which `grouped` holds (the others get `u32::MAX` and are never
/// anyone's neighbour): in node order, a node none of whose grouped neighbours (`nbrs`) is
/// in an aggregate yet starts one with them; a node left over joins the aggregate of its
/// first neighbour that has one, or makes its own. Returns each node's aggregate and the
/// count.
pub(super) fn aggregate_with<I: Iterator<Item = usize>>(
    n: usize,
    nbrs: impl Fn(usize) -> I,
    grouped: impl Fn(usize) -> bool,
) -> (Vec<u32>, usize) {
    let mut agg = vec![u32::MAX; n];
    let mut count = 0u32;
    for i in 0..n {
        if !grouped(i)
            || agg[i] != u32::MAX
            || nbrs(i).any(|j| agg[j] != u32::MAX)
        {
            continue;
        }
        agg[i] = count;
        for j in nbrs(i).filter(|&j| grouped(j)) {
            agg[j] = count;
        }
        count += 1;
    }
    for i in 0..n {
        if grouped(i) && agg[i] == u32::MAX {
            agg[i] = nbrs(i)
                .map(|j| agg[j])
                .find(|&c| c != u32::MAX)
                .unwrap_or_else(|| {
                    count += 1;
                    count - 1
                });
        }
    }
    (agg, count as usize)
}

/// The nodes of each of `count` aggregates, in compressed rows (node order within each;
/// nodes of no aggregate, `u32::MAX`, left out).
pub(super) fn members_of(agg: &[u32], count: usize) -> (Vec<u32>, Vec<u32>) {
    let mut start = vec![0u32; count + 1];
    for &c in agg.iter().filter(|&&c| c != u32::MAX) {
        start[c as usize + 1] += 1;
    }
    for c in 0..count {
        start[c + 1] += start[c];
    }
    let mut fill = start.clone();
    let mut members = vec![0u32; start[count] as usize];
    for (i, &c) in agg.iter().enumerate().filter(|(_, &c)| c != u32::MAX) {
        members[fill[c as usize] as usize] = i as u32;
        fill[c as usize] += 1;
    }
    (start, members)
}

/// The coarse matrix `Pᴴ A P` of piecewise-constant aggregates: entry (I, J) sums the
/// entries of `a` from the nodes of I to those of J.
fn galerkin(a: &Csr, agg: &[u32], members_start: &[u32], members: &[u32], count: usize) -> Csr {
    let rows: Vec<Vec<(u32, Cx)>> = (0..count)
        .into_par_iter()
        .with_min_len(256)
        .map(|c| {
            let mut row: Vec<(u32, Cx)> = Vec::new();
            for &i in &members[members_start[c] as usize..members_start[c + 1] as usize] {
                let i = i as usize;
                for e in a.start[i] as usize..a.start[i + 1] as usize {
                    row.push((agg[a.col[e] as usize], a.val[e]));
                }
            }
            row.sort_by_key(|&(j, _)| j);
            let mut out: Vec<(u32, Cx)> = Vec::with_capacity(row.len());
            for (j, v) in row {
                match out.last_mut() {
                    Some(last) if last.0 == j => last.1 = add(last.1, v),
                    _ => out.push((j, v)),
                }
            }
            out
        })
        .collect();
    let mut start = Vec::with_capacity(count + 1);
    start.push(0u32);
    let mut col = Vec::new();
    let mut val = Vec::new();
    for row in rows {
        for (j, v) in row {
            col.push(j);
            val.push(v);
        }
        start.push(col.len() as u32);
    }
    Csr { start, col, val }
}

/// The lower triangular Cholesky factor of the Hermitian matrix `a` (dense, row-major, in
/// double precision); a pivot that is not positive gives a zero row (that unknown is left
/// at 0 by the solve).
fn cholesky(a: &Csr) -> Vec<[f64; 2]> {
    let n = a.rows();
    let mut m = vec![[0.0f64; 2]; n * n];
    for i in 0..n {
        for e in a.start[i] as usize..a.start[i + 1] as usize {
            let v = a.val[e];
            m[i * n + a.col[e] as usize] = [f64::from(v[0]), f64::from(v[1])];
        }
    }
    for j in 0..n {
        let mut d = m[j * n + j][0];
        for k in 0..j {
            let v = m[j * n + k];
            d -= v[0] * v[0] + v[1] * v[1];
        }
        if d <= 0.0 || !d.is_finite() {
            for k in 0..n {
                m[j * n + k] = [0.0; 2];
            }
            continue;
        }
        let d = d.sqrt();
        m[j * n + j] = [d, 0.0];
        for i in j + 1..n {
            // L[i][j] = (A[i][j] − Σ_k L[i][k] conj(L[j][k])) / L[j][j]
            let mut s = m[i * n + j];
            for k in 0..j {
                let (x, y) = (m[i * n + k], m[j * n + k]);
                s[0] -= x[0] * y[0] + x[1] * y[1];
                s[1] -= x[1] * y[0] - x[0] * y[1];
            }
            m[i * n + j] = [s[0] / d, s[1] / d];
        }
    }
    // the upper triangle is not read: clear it so the factor is L alone
    for i in 0..n {
        for j in i + 1..n {
            m[i * n + j] = [0.0; 2];
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 2D five-point Laplacian of a k × k grid plus a small shift, as a complex matrix.
    fn laplacian(k: usize) -> Csr {
        let n = k * k;
        let mut start = vec![0u32];
        let mut col = Vec::new();
        let mut val = Vec::new();
        for y in 0..k {
            for x in 0..k {
                let i = y * k + x;
                let mut row: Vec<(u32, Cx)> = vec![(i as u32, [4.01, 0.0])];
                if x > 0 {
                    row.push((i as u32 - 1, [-1.0, 0.0]));
                }
                if x + 1 < k {
                    row.push((i as u32 + 1, [-1.0, 0.0]));
                }
                if y > 0 {
                    row.push(((i - k) as u32, [-1.0, 0.0]));
                }
                if y + 1 < k {
                    row.push(((i + k) as u32, [-1.0, 0.0]));
                }
                row.sort_by_key(|r| r.0);
                for (j, v) in row {
                    col.push(j);
                    val.push(v);
                }
                start.push(col.len() as u32);
            }
        }
        assert_eq!(start.len(), n + 1);
        Csr { start, col, val }
    }

    #[test]
    fn the_coarsest_level_is_solved_exactly() {
        let a = laplacian(12);
        let mg = Multigrid::new(laplacian(12));
        assert!(mg.levels.is_empty());
        let b: Vec<Cx> = (0..144).map(|i| [(i % 7) as f32, (i % 3) as f32]).collect();
        let mut x = vec![[0.0f32; 2]; 144];
        mg.precondition(&b, &mut x);
        let mut ax = vec![[0.0f32; 2]; 144];
        a.apply(&x, &mut ax);
        for (p, q) in ax.iter().zip(&b) {
            assert!((p[0] - q[0]).abs() < 1e-3 && (p[1] - q[1]).abs() < 1e-3);
        }
    }

    #[test]
    fn a_v_cycle_reduces_the_error_of_a_large_laplacian_severalfold() {
        let k = 100;
        let a = laplacian(k);
        let mg = Multigrid::new(laplacian(k));
        assert!(mg.levels.len() >= 2);
        // error reduction of the stationary iteration x += B (b − A x) with b = 0
        let mut x: Vec<Cx> = (0..k * k)
            .map(|i| [((i * 7919) % 101) as f32 / 50.0 - 1.0, 0.0])
            .collect();
        let norm = |v: &[Cx]| v.iter().map(|c| c[0] * c[0] + c[1] * c[1]).sum::<f32>().sqrt();
        let start = norm(&x);
        let mut r = vec![[0.0f32; 2]; k * k];
        let mut z = vec![[0.0f32; 2]; k * k];
        for _ in 0..10 {
            a.apply(&x, &mut r);
            r.iter_mut().for_each(|c| *c = [-c[0], -c[1]]);
            mg.precondition(&r, &mut z);
            x.iter_mut().zip(&z).for_each(|(x, z)| *x = add(*x, *z));
        }
        assert!(norm(&x) < 0.1 * start, "{} -> {}", start, norm(&x));
    }
}
