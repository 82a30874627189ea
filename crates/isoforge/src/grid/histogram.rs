use super::AnyGrid;

/// A histogram of a grid's values over `[min, max]` in equal bins, with summary statistics.
#[derive(Debug, Clone, PartialEq)]
pub struct Histogram {
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
    /// Mean value.
    pub mean: f64,
    /// Sample count per bin (bin `b` covers `[min + b·w, min + (b+1)·w)`, the last one closed).
    pub counts: Vec<u64>,
}

impl Histogram {
    /// A padding spike is separated from the other values by at least `bins / PADDING_GAP` empty
    /// bins (a sixteenth of the value range).
    pub const PADDING_GAP: usize = 16;

    /// The histogram of `grid` in `bins` bins (at least 1); `None` for an empty grid.
    pub fn of(grid: &AnyGrid, bins: usize) -> Option<Histogram> {
        let range = grid.value_range()?;
        let bins = bins.max(1);
        let mut counts = vec![0u64; bins];
        let (mut sum, mut n) = (0.0f64, 0u64);
        let width = (range.max - range.min) / bins as f64;
        for v in grid.values_f64() {
            let b = if width > 0.0 { (((v - range.min) / width) as usize).min(bins - 1) } else { 0 };
            counts[b] += 1;
            sum += v;
            n += 1;
        }
        Some(Histogram { min: range.min, max: range.max, mean: sum / n.max(1) as f64, counts })
    }

    /// Width of one bin.
    pub fn bin_width(&self) -> f64 {
        (self.max - self.min) / self.counts.len() as f64
    }

    /// The value below which `q` (0–1) of the samples lie, to bin resolution.
    pub fn quantile(&self, q: f64) -> f64 {
        let total: u64 = self.counts.iter().sum();
        let target = (q.clamp(0.0, 1.0) * total as f64).ceil() as u64;
        let mut acc = 0;
        for (b, &c) in self.counts.iter().enumerate() {
            acc += c;
            if acc >= target.max(1) {
                return self.min + (b as f64 + 0.5) * self.bin_width();
            }
        }
        self.max
    }

    /// Otsu's threshold: the bin boundary maximising the between-class variance. A good first
    /// iso for two-phase data such as CT (air vs tissue) without padding; see
    /// [`surface_iso`](Histogram::surface_iso) for scans with it.
    pub fn otsu(&self) -> f64 {
        self.otsu_over(0, self.counts.len())
    }

    /// A first iso for the surface of the scanned object: Otsu's threshold over the values that
    /// are not padding. Padding is a spike at either end of the range that no sample comes near:
    /// its bin is separated from the next occupied bin by at least a sixteenth of the bins
    /// ([`PADDING_GAP`](Histogram::PADDING_GAP)), and at least two occupied bins remain without it
    /// (so two- and three-level volumes keep all their values).
    /// The −2000 a CT scanner writes outside its scan circle is such a spike (Otsu over all values
    /// would split padding from everything else: −1976 on the Stanford bunny CT instead of 988);
    /// a background of zeros next to low noise is not, and stays in.
    ///
    /// Equal to [`otsu`](Histogram::otsu) when there is no padding; to bin resolution.
    pub fn surface_iso(&self) -> f64 {
        let occupied: Vec<usize> = (0..self.counts.len()).filter(|&b| self.counts[b] > 0).collect();
        let gap = (self.counts.len() / Self::PADDING_GAP).max(2);
        let (mut first, mut last) = (0, occupied.len().saturating_sub(1));
        if occupied.len() >= 3 && occupied[1] - occupied[0] >= gap {
            first = 1;
        }
        if last >= first + 2 && occupied[last] - occupied[last - 1] >= gap {
            last -= 1;
        }
        match (occupied.get(first), occupied.get(last)) {
            (Some(&lo), Some(&hi)) => self.otsu_over(lo, hi + 1),
            _ => self.otsu(),
        }
    }

    /// Otsu's threshold over bins `lo..hi` only.
    fn otsu_over(&self, lo: usize, hi: usize) -> f64 {
        let counts = &self.counts[lo..hi];
        let total: f64 = counts.iter().sum::<u64>() as f64;
        let centers: Vec<f64> = (0..counts.len()).map(|b| b as f64 + 0.5).collect();
        let sum_all: f64 = counts.iter().zip(&centers).map(|(&c, &x)| c as f64 * x).sum();
        let (mut w0, mut sum0, mut best, mut best_t) = (0.0, 0.0, -1.0, 0usize);
        for t in 0..counts.len().saturating_sub(1) {
            w0 += counts[t] as f64;
            sum0 += counts[t] as f64 * centers[t];
            let w1 = total - w0;
            if w0 == 0.0 || w1 == 0.0 {
                continue;
            }
            let (m0, m1) = (sum0 / w0, (sum_all - sum0) / w1);
            let between = w0 * w1 * (m0 - m1) * (m0 - m1);
            if between > best {
                best = between;
                best_t = t;
            }
        }
        self.min + ((lo + best_t) as f64 + 1.0) * self.bin_width()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{DenseGrid, Lattice};

    #[test]
    fn otsu_splits_two_phases() {
        let l = Lattice::new([10, 10, 10]).unwrap();
        let g: AnyGrid = DenseGrid::from_fn(l, |p| if p[0] < 5 { 10u8 } else { 200 }).into();
        let h = Histogram::of(&g, 256).unwrap();
        let t = h.otsu();
        assert!(t > 10.0 && t < 200.0, "{t}");
        assert_eq!(h.mean, 105.0);
        assert!(h.quantile(0.25) < 20.0 && h.quantile(0.75) > 190.0);
        assert_eq!(h.surface_iso(), t, "no padding: surface_iso is Otsu");
    }

    /// Two phases (air 0–40, object 180–220) with a fill value far below both, as CT scanners
    /// write outside the scan circle.
    fn padded(fill_share: u32) -> AnyGrid {
        let l = Lattice::new([100, 10, 10]).unwrap();
        DenseGrid::from_fn(l, |p| {
            let noise = ((p[1] * 7 + p[2] * 3) % 41) as i16;
            if p[0] < fill_share {
                -2000i16
            } else if p[0] < 70 {
                noise
            } else {
                180 + noise
            }
        })
        .into()
    }

    // Issue 10: `info` suggested −1976 on the bunny CT (Otsu split the −2000 padding from the rest).
    #[test]
    fn issue_10_surface_iso_ignores_padding() {
        let h = Histogram::of(&padded(40), 256).unwrap();
        assert!(h.otsu() < -1500.0, "plain Otsu splits off the padding: {}", h.otsu());
        let s = h.surface_iso();
        assert!(s > 40.0 && s < 180.0, "between air and object: {s}");
        // The same volume without padding gives the same iso, to bin resolution.
        let l = Lattice::new([60, 10, 10]).unwrap();
        let g: AnyGrid = DenseGrid::from_fn(l, |p| {
            let noise = ((p[1] * 7 + p[2] * 3) % 41) as i16;
            if p[0] < 30 {
                noise
            } else {
                180 + noise
            }
        })
        .into();
        let plain = Histogram::of(&g, 256).unwrap().surface_iso();
        assert!((s - plain).abs() <= 2.0 * h.bin_width(), "{s} vs {plain}");
    }

    #[test]
    fn surface_iso_keeps_two_level_and_contiguous_volumes() {
        // A binary mask: both ends are isolated, but dropping either would leave one value.
        let l = Lattice::new([10, 10, 10]).unwrap();
        let g: AnyGrid = DenseGrid::from_fn(l.clone(), |p| u8::from(p[0] < 3)).into();
        let h = Histogram::of(&g, 256).unwrap();
        assert_eq!(h.surface_iso(), h.otsu());
        assert!(h.surface_iso() > 0.0 && h.surface_iso() < 1.0);
        // A large background of zeros next to low values is data, not padding.
        let g: AnyGrid = DenseGrid::from_fn(l, |p| if p[0] < 6 { 0u8 } else { (1 + p[1] * 10 + p[2]) as u8 }).into();
        let h = Histogram::of(&g, 256).unwrap();
        assert_eq!(h.surface_iso(), h.otsu());
    }
}
