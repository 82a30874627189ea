//! Colour maps for vertex colours (`--colormap`): piecewise-linear through anchor colours.

/// A named colour map.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Colormap {
    /// Perceptually uniform dark blue → green → yellow (matplotlib's viridis, 9 anchors).
    Viridis,
    /// Black → white.
    Gray,
    /// Black → red → yellow → white.
    Hot,
    /// Blue → light grey → red, diverging (Moreland's cool-warm).
    Coolwarm,
}

const VIRIDIS: [[u8; 3]; 9] = [
    [68, 1, 84],
    [71, 44, 122],
    [59, 82, 139],
    [44, 113, 142],
    [33, 145, 140],
    [39, 173, 129],
    [92, 200, 99],
    [170, 220, 50],
    [253, 231, 37],
];
const GRAY: [[u8; 3]; 2] = [[0, 0, 0], [255, 255, 255]];
const HOT: [[u8; 3]; 4] = [[0, 0, 0], [230, 0, 0], [255, 210, 0], [255, 255, 255]];
const COOLWARM: [[u8; 3]; 3] = [[59, 76, 192], [221, 221, 221], [180, 4, 38]];

impl Colormap {
    /// Every map, with its CLI name.
    pub const ALL: [(Colormap, &'static str); 4] = [
        (Colormap::Viridis, "viridis"),
        (Colormap::Gray, "gray"),
        (Colormap::Hot, "hot"),
        (Colormap::Coolwarm, "coolwarm"),
    ];

    /// Parses a CLI name.
    pub fn parse(s: &str) -> Option<Colormap> {
        Self::ALL.iter().find(|(_, n)| *n == s).map(|(m, _)| *m)
    }

    fn anchors(self) -> &'static [[u8; 3]] {
        match self {
            Colormap::Viridis => &VIRIDIS,
            Colormap::Gray => &GRAY,
            Colormap::Hot => &HOT,
            Colormap::Coolwarm => &COOLWARM,
        }
    }

    /// The colour at `t` ∈ [0, 1] (clamped; NaN maps to 0).
    pub fn at(self, t: f64) -> [u8; 3] {
        let a = self.anchors();
        let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) } * (a.len() - 1) as f64;
        let i = (t.floor() as usize).min(a.len() - 2);
        let f = t - i as f64;
        [0, 1, 2].map(|c| (a[i][c] as f64 + (a[i + 1][c] as f64 - a[i][c] as f64) * f).round() as u8)
    }

    /// Colours for `values` mapped linearly from `lo..hi` onto the map.
    pub fn colors(self, values: &[f32], lo: f64, hi: f64) -> Vec<[u8; 3]> {
        let span = if hi > lo { hi - lo } else { 1.0 };
        values.iter().map(|&v| self.at((v as f64 - lo) / span)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ends_and_middle() {
        assert_eq!(Colormap::Viridis.at(0.0), [68, 1, 84]);
        assert_eq!(Colormap::Viridis.at(1.0), [253, 231, 37]);
        assert_eq!(Colormap::Viridis.at(0.5), [33, 145, 140]);
        assert_eq!(Colormap::Gray.at(0.5), [128, 128, 128]);
        assert_eq!(Colormap::Gray.at(-3.0), [0, 0, 0]);
        assert_eq!(Colormap::Gray.at(f64::NAN), [0, 0, 0]);
        assert_eq!(Colormap::parse("hot"), Some(Colormap::Hot));
        assert_eq!(Colormap::Coolwarm.colors(&[0.0, 10.0], 0.0, 10.0), vec![[59, 76, 192], [180, 4, 38]]);
    }
}
