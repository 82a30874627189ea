//! Exact Euclidean distances on a [`CellComplex`]'s doubled grid, from every element to the
//! nearest absent one (Felzenszwalb and Huttenlocher's lower envelope of parabolas, one axis at
//! a time): how far the solid reaches around an element, the thickness that sizes a handle.

use super::complex::CellComplex;

/// The squared distance (world units; a doubled step along axis `a` is `step[a]`) from every
/// element to the nearest absent element; `f32::INFINITY` when none is absent.
pub fn squared_distance_to_absent(c: &CellComplex, step: [f64; 3]) -> Vec<f32> {
    let d = c.dims();
    let mut out: Vec<f32> = (0..c.len()).map(|i| if c.contains(i) { f32::INFINITY } else { 0.0 }).collect();
    let longest = d.iter().copied().max().unwrap_or(0);
    let (mut f, mut g) = (vec![0f64; longest], vec![0f64; longest]);
    let (mut v, mut z) = (vec![0usize; longest], vec![0f64; longest + 1]);
    let strides = [1, d[0], d[0] * d[1]];
    for a in 0..3 {
        let (n, s) = (d[a], strides[a]);
        let lines = c.len() / n;
        for line in 0..lines {
            // The line's first element: every index whose coordinate along `a` is 0.
            let start = match a {
                0 => line * d[0],
                1 => line % d[0] + line / d[0] * d[0] * d[1],
                _ => line,
            };
            for q in 0..n {
                f[q] = out[start + q * s] as f64;
            }
            envelope(&f[..n], step[a], &mut g[..n], &mut v, &mut z);
            for q in 0..n {
                out[start + q * s] = g[q] as f32;
            }
        }
    }
    out
}

/// `g[q] = min_p (q − p)²·h² + f[p]` over the finite `f[p]`.
fn envelope(f: &[f64], h: f64, g: &mut [f64], v: &mut [usize], z: &mut [f64]) {
    let pos = |q: usize| q as f64 * h;
    let mut k: isize = -1;
    for q in 0..f.len() {
        if !f[q].is_finite() {
            continue;
        }
        loop {
            if k < 0 {
                k = 0;
                v[0] = q;
                z[0] = f64::NEG_INFINITY;
                z[1] = f64::INFINITY;
                break;
            }
            let p = v[k as usize];
            let cross = ((f[q] + pos(q) * pos(q)) - (f[p] + pos(p) * pos(p))) / (2.0 * (pos(q) - pos(p)));
            if cross <= z[k as usize] {
                k -= 1;
                continue;
            }
            k += 1;
            v[k as usize] = q;
            z[k as usize] = cross;
            z[k as usize + 1] = f64::INFINITY;
            break;
        }
    }
    if k < 0 {
        g.fill(f64::INFINITY);
        return;
    }
    let mut j = 0;
    for q in 0..f.len() {
        while z[j + 1] < pos(q) {
            j += 1;
        }
        let p = v[j];
        g[q] = (pos(q) - pos(p)).powi(2) + f[p];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distances_equal_brute_force_on_a_random_solid() {
        let n = 7;
        let mut seed = 12345u64;
        let solid: Vec<bool> = (0..n * n * n)
            .map(|_| {
                seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                !(seed >> 33).is_multiple_of(4)
            })
            .collect();
        let c = CellComplex::of_solid([n; 3], &solid);
        let step = [0.5, 0.75, 1.0];
        let got = squared_distance_to_absent(&c, step);
        for i in 0..c.len() {
            let x = c.coords(i);
            let want = (0..c.len())
                .filter(|&j| !c.contains(j))
                .map(|j| {
                    let y = c.coords(j);
                    (0..3).map(|a| ((x[a] as f64 - y[a] as f64) * step[a]).powi(2)).sum::<f64>()
                })
                .fold(f64::INFINITY, f64::min);
            assert!((got[i] as f64 - want).abs() <= 1e-5 * want.max(1.0), "{x:?}: {} vs {want}", got[i]);
        }
    }
}
