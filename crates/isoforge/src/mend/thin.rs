//! Topology-preserving thinning of a [`CellComplex`] by collapses.
//!
//! A *free pair* is an element σ with exactly one present coface τ, τ having no present coface
//! itself; removing both (an elementary collapse) keeps the homotopy type, so handles and
//! tunnels survive thinning exactly. Thinning runs in rounds: each round finds the pairs free
//! at its start and removes those still free when their turn comes, so the complex shrinks one
//! layer per round from every side and what remains is centred (TopoMender's two traversals per
//! step). A solid ball ends as one point, a solid torus as one cycle of edges; thinning stops
//! early only where no pair is free (a 2D sheet that bounds a cavity).

use super::complex::CellComplex;

/// What a thinning did.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Thinning {
    /// Rounds run.
    pub rounds: u32,
    /// The pairs collapsed `(σ, τ)`, in order: played backwards they pull a cochain of the
    /// thinned complex back onto the whole (the membranes of [`super::repair`]).
    pub pairs: Vec<(u32, u32)>,
}

/// Thins `c` until no free pair remains; with `keep_border`, elements on the grid's outer layer
/// are never removed.
pub fn thin(c: &mut CellComplex, keep_border: bool) -> Thinning {
    let n = c.len();
    let mut frontier: Vec<u32> = (0..n).filter(|&i| c.contains(i) && c.dimension(i) < 3).map(|i| i as u32).collect();
    let mut t = Thinning::default();
    let mut queued = vec![false; n];
    let mut next = Vec::new();
    loop {
        let free: Vec<u32> =
            frontier.iter().copied().filter(|&s| free_coface(c, s as usize, keep_border).is_some()).collect();
        for &s in &frontier {
            queued[s as usize] = false;
        }
        if free.is_empty() {
            break;
        }
        t.rounds += 1;
        for s in free {
            let s = s as usize;
            let Some(tau) = free_coface(c, s, keep_border) else { continue };
            c.remove(s);
            c.remove(tau);
            t.pairs.push((s as u32, tau as u32));
            // Whatever may have become free: the faces of tau (fewer cofaces, maybe maximal
            // now) and their faces (a maximal coface now).
            for (r, _) in c.faces(tau) {
                for x in std::iter::once(r).chain(c.faces(r).map(|(f, _)| f)) {
                    if c.contains(x) && !queued[x] {
                        queued[x] = true;
                        next.push(x as u32);
                    }
                }
            }
        }
        std::mem::swap(&mut frontier, &mut next);
        next.clear();
    }
    t
}

/// The coface `s` collapses with, when `s` is present with exactly one present coface and that
/// coface has none.
#[inline]
fn free_coface(c: &CellComplex, s: usize, keep_border: bool) -> Option<usize> {
    if !c.contains(s) || keep_border && c.on_border(s) {
        return None;
    }
    let (count, tau) = c.present_cofaces(s);
    (count == 1 && c.present_cofaces(tau).0 == 0).then_some(tau)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A solid square tube of `w × w` points around a ring of side `side`, in the z = const
    /// planes `1..1 + h`.
    fn ring(n: usize, w: usize, lo: usize, side: usize, h: usize) -> Vec<bool> {
        (0..n * n * n)
            .map(|i| {
                let p = [i % n, i / n % n, i / (n * n)];
                let in_box = |a: usize, b: usize| (a..b).contains(&p[0]) && (a..b).contains(&p[1]);
                p[2] >= 1 && p[2] < 1 + h && in_box(lo, lo + side) && !in_box(lo + w, lo + side - w)
            })
            .collect()
    }

    #[test]
    fn a_ball_thins_to_one_point_and_a_ring_to_one_cycle() {
        let n = 14;
        let solid: Vec<bool> = (0..n * n * n)
            .map(|i| {
                let p = [i % n, i / n % n, i / (n * n)].map(|v| v as f64 - 6.5);
                p.iter().map(|v| v * v).sum::<f64>() < 25.0
            })
            .collect();
        let mut c = CellComplex::of_solid([n; 3], &solid);
        thin(&mut c, false);
        assert_eq!(c.counts(), [1, 0, 0, 0]);

        let solid = ring(n, 3, 1, 12, 3);
        let mut c = CellComplex::of_solid([n; 3], &solid);
        assert_eq!(c.euler(), 0);
        let t = thin(&mut c, false);
        let k = c.counts();
        assert_eq!((k[2], k[3]), (0, 0), "{k:?}");
        assert_eq!(k[0], k[1], "one cycle: {k:?}");
        // Centred: the cycle runs through the middle of the 3-point-wide tube.
        for i in 0..c.len() {
            if c.contains(i) {
                let x = c.coords(i);
                assert_eq!(x[2], 4, "z of {x:?}");
            }
        }
        assert!(t.rounds >= 2, "{t:?}");
    }
}
