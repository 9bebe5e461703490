//! The vector algebra of the area checks: vector areas of polygons, the area of a
//! surface's faces, and the plane of a planar surface.

use super::*;

pub(super) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(super) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub(super) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Twice the vector area of a polygon (sum of `p_i × p_{i+1}` about its first vertex).
pub(super) fn vector_area(poly: &[[f64; 3]]) -> [f64; 3] {
    let mut s = [0.0; 3];
    for i in 1..poly.len().saturating_sub(1) {
        let c = cross(sub(poly[i], poly[0]), sub(poly[i + 1], poly[0]));
        for k in 0..3 {
            s[k] += c[k];
        }
    }
    s
}

/// Twice the summed vector area of `faces` of `m` (by chunks of faces in parallel added in
/// order: the same sum for any thread count); the first face with an unknown node is an
/// error.
pub(super) fn area(
    faces: &[&[u64]],
    idx: &TagCoords,
    s: i32,
    input: bool,
) -> Result<[f64; 3], InvariantViolation> {
    // faces have 3 or 4 nodes: no allocation per face
    let pts4 = |f: &[u64]| -> Option<([[f64; 3]; 4], usize)> {
        let mut p = [[0.0; 3]; 4];
        for (x, &t) in p.iter_mut().zip(f) {
            *x = idx.get(t)?;
        }
        Some((p, f.len().min(4)))
    };
    let parts: Vec<Result<[f64; 3], InvariantViolation>> = faces
        .par_chunks(CHUNK)
        .map(|c| {
            let mut t = [0.0; 3];
            for f in c {
                let p = pts4(f).ok_or_else(|| InvariantViolation::UnknownNode {
                    surface: s,
                    input,
                    nodes: f.to_vec(),
                })?;
                let a = vector_area(&p.0[..p.1]);
                for k in 0..3 {
                    t[k] += a[k];
                }
            }
            Ok(t)
        })
        .collect();
    let mut total = [0.0; 3];
    for p in parts {
        let p = p?;
        for k in 0..3 {
            total[k] += p[k];
        }
    }
    Ok(total)
}

/// The unit normal `total` of `faces` when they are planar: every corner within 1e-10 of
/// the extent (the largest distance from the first corner) of the plane through the first
/// corner. `None` when they are not, or `total` is zero.
pub(super) fn plane_of(ib: &TagCoords, faces: &[&[u64]], total: [f64; 3]) -> Option<[f64; 3]> {
    let norm = dot(total, total).sqrt();
    if norm == 0.0 {
        return None;
    }
    let n = total.map(|x| x / norm);
    let o = faces
        .first()
        .and_then(|f| f.first())
        .and_then(|&t| ib.get(t))
        .unwrap_or([0.0; 3]);
    // (extent, largest distance from the plane, a distance that is not a number)
    let spread = |c: &[&[u64]]| {
        let mut r = (0.0_f64, 0.0_f64, false);
        for p in c.iter().flat_map(|f| f.iter().filter_map(|&t| ib.get(t))) {
            let d = sub(p, o);
            r.0 = r.0.max(dot(d, d).sqrt());
            let off = dot(d, n).abs();
            r.1 = r.1.max(off);
            r.2 |= off.is_nan();
        }
        r
    };
    let (extent, off, nan) = faces.par_chunks(CHUNK).map(spread).reduce(
        || (0.0, 0.0, false),
        |a, b| (a.0.max(b.0), a.1.max(b.1), a.2 || b.2),
    );
    (!nan && off <= 1e-10 * extent.max(f64::MIN_POSITIVE)).then_some(n)
}
