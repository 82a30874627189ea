//! Quadratic error functions of Hermite data: the point that best fits a set of tangent planes,
//! solved by a symmetric eigen-decomposition with small singular values truncated \[Ju02\].
//!
//! In: crossings and normals in one frame (a cell's coordinates). Out: the minimiser nearest the
//! crossings' mean (the mass point) along the directions the planes leave free.

use glam::DVec3;

/// The sums a quadratic error function `E(x) = Σ (nᵢ · (x − pᵢ))²` needs: `AᵀA`, `Aᵀb`, the mass
/// point's sum, and the count. Accumulated in `f64`; the planes are added in any order.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Qef {
    /// `Σ n nᵀ` (symmetric, full).
    ata: [[f64; 3]; 3],
    /// `Σ n (n · p)`.
    atb: [f64; 3],
    /// `Σ p`.
    mass: [f64; 3],
    /// Planes added.
    count: u32,
}

/// Which singular values of the QEF [`Qef::solve`] keeps, and how far it moved.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QefSolution {
    /// The minimiser (the mass point plus the least-norm correction in the kept directions).
    pub point: [f64; 3],
    /// Directions kept (0: no plane, or all normals zero; 1: a plane; 2: a crease; 3: a corner).
    pub rank: u8,
}

impl Qef {
    /// Adds the tangent plane through `p` with normal `n` (any length: the length weighs it).
    #[inline]
    pub fn add(&mut self, p: [f32; 3], n: [f32; 3]) {
        let (p, n) = (p.map(f64::from), n.map(f64::from));
        let d = n[0] * p[0] + n[1] * p[1] + n[2] * p[2];
        for r in 0..3 {
            for c in 0..3 {
                self.ata[r][c] += n[r] * n[c];
            }
            self.atb[r] += n[r] * d;
            self.mass[r] += p[r];
        }
        self.count += 1;
    }

    /// The planes added.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// The mean of the points added (the origin of the solve; `None` without points).
    pub fn mass_point(&self) -> Option<[f64; 3]> {
        (self.count > 0).then(|| self.mass.map(|s| s / self.count as f64))
    }

    /// The error `E(x)` at `x` (for tests and reports): `xᵀAᵀAx − 2xᵀAᵀb + bᵀb` without the
    /// constant `bᵀb`, so only differences between points mean something.
    pub fn relative_error(&self, x: [f64; 3]) -> f64 {
        let mut e = 0.0;
        for r in 0..3 {
            for c in 0..3 {
                e += x[r] * self.ata[r][c] * x[c];
            }
            e -= 2.0 * x[r] * self.atb[r];
        }
        e
    }

    /// The minimiser of `E` nearest the mass point `c`: `x = c + V Σ⁺ Vᵀ (Aᵀb − AᵀA c)`, where
    /// `AᵀA = V Λ Vᵀ` and `Σ⁺` inverts the eigenvalues `λ ≥ truncation² · λ_max` (singular values
    /// `σ = √λ` at least `truncation` times the largest) and zeroes the others, so directions the
    /// planes barely constrain (a flat patch's tangent directions, a crease's direction) stay at
    /// the mass point instead of running off along noise. `None` without points.
    pub fn solve(&self, truncation: f64) -> Option<QefSolution> {
        let c = self.mass_point()?;
        let (values, vectors) = symmetric_eigen(self.ata);
        let largest = values.iter().fold(0.0f64, |m, &v| m.max(v));
        let mut point = c;
        let mut rank = 0;
        if largest > 0.0 && largest.is_finite() {
            // The residual's right-hand side at the mass point.
            let r: [f64; 3] = [0, 1, 2].map(|i| self.atb[i] - (0..3).map(|j| self.ata[i][j] * c[j]).sum::<f64>());
            for k in 0..3 {
                if values[k] < truncation * truncation * largest || values[k] <= 0.0 {
                    continue;
                }
                rank += 1;
                let v = [vectors[0][k], vectors[1][k], vectors[2][k]];
                let along = (v[0] * r[0] + v[1] * r[1] + v[2] * r[2]) / values[k];
                for i in 0..3 {
                    point[i] += along * v[i];
                }
            }
        }
        if point.iter().any(|x| !x.is_finite()) {
            return Some(QefSolution { point: c, rank: 0 });
        }
        Some(QefSolution { point, rank })
    }
}

/// A [`Qef`] that also keeps the constant `bᵀb = Σ (nᵢ · pᵢ)²`, so its error at a point is absolute
/// (the sum of squared distances to the planes) and QEFs of neighbouring cells can be summed into
/// their parent's (adaptive dual contouring's merge test, \[Ju02\] §4.1).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct QefSum {
    /// The sums the solve needs.
    pub qef: Qef,
    /// `Σ (n · p)²`.
    btb: f64,
}

impl QefSum {
    /// Adds the tangent plane through `p` with normal `n` (coordinates in `f64`: a frame shared
    /// by the cells summed, such as lattice indices).
    #[inline]
    pub fn add(&mut self, p: [f64; 3], n: [f64; 3]) {
        let d = n[0] * p[0] + n[1] * p[1] + n[2] * p[2];
        for r in 0..3 {
            for c in 0..3 {
                self.qef.ata[r][c] += n[r] * n[c];
            }
            self.qef.atb[r] += n[r] * d;
            self.qef.mass[r] += p[r];
        }
        self.qef.count += 1;
        self.btb += d * d;
    }

    /// Adds every plane of `other` (the planes of both, as if added one by one).
    pub fn merge(&mut self, other: &QefSum) {
        for r in 0..3 {
            for c in 0..3 {
                self.qef.ata[r][c] += other.qef.ata[r][c];
            }
            self.qef.atb[r] += other.qef.atb[r];
            self.qef.mass[r] += other.qef.mass[r];
        }
        self.qef.count += other.qef.count;
        self.btb += other.btb;
    }

    /// `E(x) = Σ (nᵢ · (x − pᵢ))²`, the sum of the squared (normal-weighted) distances of `x` from
    /// the planes; never negative (rounding clamped).
    pub fn error(&self, x: [f64; 3]) -> f64 {
        (self.qef.relative_error(x) + self.btb).max(0.0)
    }
}

/// Eigen-decomposition of a symmetric 3×3 matrix in closed form: the eigenvalues and the
/// eigenvectors as the columns of the second matrix (`a = V diag(λ) Vᵀ`, `V` orthonormal,
/// `λ₀ ≤ λ₁ ≤ λ₂`). `a` must be symmetric.
///
/// The roots of the characteristic cubic by the trigonometric formula on the shifted, scaled
/// matrix `B = (a − q I) / p` (`q` the mean eigenvalue, `p` the deviation): `βₖ = 2 cos(φ +
/// 2πk/3)` with `cos 3φ = det(B)/2`. Only the root farthest from the other two (the largest when
/// `det B ≥ 0`, else the smallest) is taken from it — the formula is accurate to `ε` for that
/// one but only to `√ε` for a pair of (nearly) equal roots. Its eigenvector is the longest cross
/// product of two rows of `a − λ I`; the other two eigenpairs are those of `a` restricted to the
/// plane orthogonal to it, a 2×2 symmetric problem solved exactly (and well posed when they are
/// equal: any basis of the plane is right). Errors are `O(ε · max|aᵢⱼ|)`. About 4× faster than
/// the cyclic Jacobi rotations it replaced (dual contouring's largest cost before).
pub fn symmetric_eigen(a: [[f64; 3]; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    const IDENTITY: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    // Scaled by the largest entry so that squares and cubes neither overflow nor underflow.
    let scale = a.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
    if !scale.is_finite() {
        return ([a[0][0], a[1][1], a[2][2]], IDENTITY);
    }
    let m = a.map(|r| r.map(|x| if scale > 0.0 { x / scale } else { 0.0 }));
    let off = m[0][1] * m[0][1] + m[0][2] * m[0][2] + m[1][2] * m[1][2];
    let rows = m.map(DVec3::from_array);
    let first = if off == 0.0 {
        // Diagonal: the axis whose value is farthest from the others' mean.
        let d = [m[0][0], m[1][1], m[2][2]];
        let apart = |i: usize| (d[i] - (d[(i + 1) % 3] + d[(i + 2) % 3]) / 2.0).abs();
        let i = (0..3).max_by(|&i, &j| apart(i).total_cmp(&apart(j))).unwrap_or(0);
        DVec3::AXES[i]
    } else {
        let q = (m[0][0] + m[1][1] + m[2][2]) / 3.0;
        let (b00, b11, b22) = (m[0][0] - q, m[1][1] - q, m[2][2] - q);
        let p = ((b00 * b00 + b11 * b11 + b22 * b22 + 2.0 * off) / 6.0).sqrt();
        // det(B) / 2 with B = (m − qI) / p, clamped against rounding.
        let det = b00 * (b11 * b22 - m[1][2] * m[1][2]) - m[0][1] * (m[0][1] * b22 - m[1][2] * m[0][2])
            + m[0][2] * (m[0][1] * m[1][2] - b11 * m[0][2]);
        let half_det = (det / (2.0 * p * p * p)).clamp(-1.0, 1.0);
        let (sin, cos) = (half_det.acos() / 3.0).sin_cos();
        // For φ ∈ [0, π/3]: 2cos φ is the largest root, 2cos(φ + 2π/3) the smallest.
        let lambda = if half_det >= 0.0 { q + 2.0 * p * cos } else { q - p * (cos + 3f64.sqrt() * sin) };
        simple_eigenvector(&rows, lambda)
    };
    let lambda_first = first.dot(apply(&rows, first));
    // The plane orthogonal to `first`, and `m` restricted to it: [[a, b], [b, c]].
    let u = first.any_orthonormal_vector();
    let v = first.cross(u);
    let (mu, mv) = (apply(&rows, u), apply(&rows, v));
    let (pa, pb, pc) = (u.dot(mu), u.dot(mv), v.dot(mv));
    let mean = (pa + pc) / 2.0;
    let half = (pa - pc) / 2.0;
    let radius = (half * half + pb * pb).sqrt();
    // The larger root's vector, (b, λ − a) or (λ − c, b): the longer of the two (both vanish
    // only when the roots are equal, and then any basis of the plane is right).
    let (x, y) = if half >= 0.0 { (half + radius, pb) } else { (pb, radius - half) };
    let len = (x * x + y * y).sqrt();
    let (cos, sin) = if len > 0.0 { (x / len, y / len) } else { (1.0, 0.0) };
    let big = cos * u + sin * v;
    let small = -sin * u + cos * v;
    let mut pairs = [(lambda_first, first), (mean + radius, big), (mean - radius, small)];
    pairs.sort_by(|x, y| x.0.total_cmp(&y.0));
    let values = pairs.map(|(l, _)| l * scale);
    let vectors = [0, 1, 2].map(|i| pairs.map(|(_, c)| c[i]));
    (values, vectors)
}

/// `m · x` for `m` given by its rows.
#[inline]
fn apply(m: &[DVec3; 3], x: DVec3) -> DVec3 {
    DVec3::new(m[0].dot(x), m[1].dot(x), m[2].dot(x))
}

/// The unit eigenvector of symmetric `m` for `lambda`, a root apart from the other two: the
/// longest cross product of two rows of `m − λ I` (orthogonal to both, so in its null space).
fn simple_eigenvector(m: &[DVec3; 3], lambda: f64) -> DVec3 {
    let r = [0, 1, 2].map(|i| m[i] - lambda * DVec3::AXES[i]);
    let c = [r[0].cross(r[1]), r[0].cross(r[2]), r[1].cross(r[2])];
    let best = c.into_iter().max_by(|x, y| x.length_squared().total_cmp(&y.length_squared()));
    best.and_then(DVec3::try_normalize).unwrap_or(DVec3::X)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small seeded generator (xorshift) for values in [−1, 1).
    fn rng(seed: u64) -> impl FnMut() -> f64 {
        let mut s = seed;
        move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 52) as f64 - 1.0
        }
    }

    /// Random symmetric matrices (full rank, rank-deficient, repeated eigenvalues) are rebuilt from
    /// their decomposition, whose vectors are orthonormal.
    #[test]
    fn eigen_decomposition_rebuilds_random_symmetric_matrices() {
        let mut r = rng(0x9e37_79b9_7f4a_7c15);
        for trial in 0..2000 {
            let mut a = [[0.0; 3]; 3];
            // Sums of 0–4 outer products: ranks 0–3, the QEF's own matrices.
            for _ in 0..trial % 5 {
                let n = [r(), r(), r()];
                for i in 0..3 {
                    for j in 0..3 {
                        a[i][j] += n[i] * n[j];
                    }
                }
            }
            if trial % 7 == 0 {
                a = [[2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0 + r() * 1e-12]];
            }
            if trial % 11 == 0 {
                // Rotated, with two or three (nearly) equal roots: where the cubic's formula is
                // only √ε-accurate and eigenvectors are free in a plane.
                let q = DVec3::new(r(), r(), r()).try_normalize().unwrap_or(DVec3::Z);
                let rot = glam::DMat3::from_axis_angle(q, r() * 3.0);
                let near = [1.0, 1.0 + r() * 1e-9 * f64::from(u8::from(trial % 2 == 0)), 1.0 + (trial % 3) as f64];
                let l = glam::DMat3::from_diagonal(DVec3::from_array(near));
                let m = rot * l * rot.transpose();
                a = [0, 1, 2].map(|i| [0, 1, 2].map(|j| m.col(j)[i]));
                a[1][0] = a[0][1];
                a[2][0] = a[0][2];
                a[2][1] = a[1][2];
            }
            let (l, v) = symmetric_eigen(a);
            let scale = a.iter().flatten().fold(1e-300f64, |m, x| m.max(x.abs()));
            for i in 0..3 {
                for j in 0..3 {
                    let rebuilt: f64 = (0..3).map(|k| v[i][k] * l[k] * v[j][k]).sum();
                    assert!((rebuilt - a[i][j]).abs() <= 1e-12 * scale, "trial {trial}: {a:?} → {l:?}, {v:?}");
                    let dot: f64 = (0..3).map(|k| v[k][i] * v[k][j]).sum();
                    assert!((dot - f64::from(u8::from(i == j))).abs() < 1e-12, "trial {trial}: not orthonormal");
                }
            }
            assert!(l.iter().all(|&x| x >= -1e-12 * scale), "trial {trial}: a sum of squares has λ ≥ 0: {l:?}");
        }
    }

    /// Three planes of a corner meet at the corner whatever the crossings on them; two planes (a
    /// crease) leave the crease's direction at the mass point; one plane projects the mass point.
    #[test]
    fn planes_meet_at_corners_and_creases_keep_the_mass_point() {
        let corner = [0.3, 0.6, 0.45];
        // A rotated frame: unit normals of three perpendicular planes.
        let (a, b) = (0.4f64, 0.7f64);
        let n = [
            [a.cos() * b.cos(), a.sin() * b.cos(), b.sin()],
            [-a.sin(), a.cos(), 0.0],
            [-a.cos() * b.sin(), -a.sin() * b.sin(), b.cos()],
        ];
        let mut r = rng(7);
        let on_plane = |k: usize, r: &mut dyn FnMut() -> f64| {
            // A point of plane k: the corner moved along the two other normals.
            let (u, w) = (n[(k + 1) % 3], n[(k + 2) % 3]);
            let (s, t) = (r() * 0.4, r() * 0.4);
            [0, 1, 2].map(|i| (corner[i] + s * u[i] + t * w[i]) as f32)
        };
        for planes in 1..=3usize {
            let mut q = Qef::default();
            for k in 0..planes {
                for _ in 0..2 {
                    q.add(on_plane(k, &mut r), n[k].map(|x| x as f32));
                }
            }
            let s = q.solve(0.1).unwrap();
            assert_eq!(s.rank as usize, planes);
            let c = q.mass_point().unwrap();
            for (k, nk) in n.iter().enumerate() {
                let d = (0..3).map(|i| nk[i] * (s.point[i] - corner[i])).sum::<f64>();
                let from_mass = (0..3).map(|i| nk[i] * (s.point[i] - c[i])).sum::<f64>();
                if k < planes {
                    assert!(d.abs() < 1e-6, "{planes} planes: off plane {k} by {d}");
                } else {
                    // Free directions keep the mass point's coordinate.
                    assert!(from_mass.abs() < 1e-6, "{planes} planes: moved {from_mass} along free {k}");
                }
            }
        }
    }

    /// Nearly parallel planes (a slightly curved patch) are one plane after truncation: the point
    /// stays near the mass point instead of shooting off to where the planes meet.
    #[test]
    fn nearly_parallel_planes_are_truncated() {
        let mut q = Qef::default();
        q.add([0.2, 0.5, 0.5], [0.0, 0.0, 1.0]);
        q.add([0.8, 0.5, 0.52], [0.02, 0.0, 0.9998]);
        let s = q.solve(0.1).unwrap();
        assert_eq!(s.rank, 1);
        assert!((s.point[0] - 0.5).abs() < 0.02 && (s.point[2] - 0.5).abs() < 0.02, "{:?}", s.point);
        // Without truncation the planes meet far away.
        let wild = q.solve(0.0).unwrap();
        assert_eq!(wild.rank, 2);
        assert!((wild.point[2] - 0.5).abs() > 1.0 || (wild.point[0] - 0.5).abs() > 1.0, "{:?}", wild.point);
        assert!(Qef::default().solve(0.1).is_none());
    }

    /// The solution minimises the error over the kept directions: no random step from it (in the
    /// span of the kept directions) lowers `E`.
    #[test]
    fn solution_is_a_minimum() {
        let mut r = rng(42);
        for _ in 0..300 {
            let mut q = Qef::default();
            for _ in 0..(2 + (r().abs() * 6.0) as usize) {
                let n = [r(), r(), r()].map(|x| x as f32);
                q.add([r(), r(), r()].map(|x| (x * 0.5 + 0.5) as f32), n);
            }
            let s = q.solve(1e-6).unwrap();
            let e0 = q.relative_error(s.point);
            for _ in 0..10 {
                let step = [r(), r(), r()].map(|x| x * 1e-3);
                let e = q.relative_error([0, 1, 2].map(|i| s.point[i] + step[i]));
                assert!(e >= e0 - 1e-9 * e0.abs().max(1.0), "{e} < {e0}");
            }
        }
    }

    /// Summed QEFs equal the QEF of all planes, and their error is the sum of squared distances.
    #[test]
    fn summed_qefs_measure_absolute_distances() {
        let mut r = rng(3);
        let (mut a, mut b, mut all) = (QefSum::default(), QefSum::default(), QefSum::default());
        let mut planes = Vec::new();
        for i in 0..9 {
            let n = [r(), r(), r()];
            let p = [r() + 10.0, r() - 4.0, r() * 3.0];
            planes.push((p, n));
            all.add(p, n);
            if i % 2 == 0 {
                a.add(p, n)
            } else {
                b.add(p, n)
            }
        }
        a.merge(&b);
        assert_eq!(a.qef.count(), 9);
        let x = [10.2, -3.9, 0.4];
        let direct: f64 = planes.iter().map(|(p, n)| (0..3).map(|i| n[i] * (x[i] - p[i])).sum::<f64>().powi(2)).sum();
        assert!((a.error(x) - direct).abs() < 1e-9 * direct.max(1.0), "{} vs {direct}", a.error(x));
        assert!((all.error(x) - direct).abs() < 1e-9 * direct.max(1.0));
        // Three planes through one point: no error there.
        let mut corner = QefSum::default();
        for n in [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.6, 0.0, 0.8]] {
            corner.add([7.0, 8.0, 9.0], n);
        }
        assert!(corner.error([7.0, 8.0, 9.0]) < 1e-9);
        assert!((corner.error([8.0, 8.0, 9.0]) - 1.36).abs() < 1e-9);
    }
}
