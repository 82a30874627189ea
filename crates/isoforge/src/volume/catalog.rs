//! Built-in fields by name, for the command line and the demo: `gyroid?n=128&periods=4`.
//!
//! | name | field | domain | default iso |
//! |---|---|---|---|
//! | `sphere` (`r`) | [`Sphere`] SDF, r 0.7 | [-1, 1]³ | 0, inside below |
//! | `torus` (`R`, `r`) | [`Torus`] SDF, 0.6 / 0.25 | [-1, 1]³ | 0, inside below |
//! | `box` (`h`) | [`Cuboid`] SDF, half size 0.6 | [-1, 1]³ | 0, inside below |
//! | `gyroid` (`periods`, `clip`) | [`Gyroid`], 2 periods, clipped to a ball of radius `clip` if given | [-1, 1]³ | 0, inside below |
//! | `metaballs` (`t`) | [`ChargePoints`] at time t (0.5) | [0, 1]³ | 48, inside above |
//! | `lines` (`t`) | [`ChargeLines`] at time t (0.5) | [0, 1]³ | 48, inside above |
//! | `height` | [`HeightField`] | [0, 1]³ | 48, inside below |
//! | `rotated-box` (`hx`, `hy`, `hz`; turn) | [`RotatedBox`], half sizes 0.6 × 0.45 × 0.35 | [-1, 1]³ | 0, inside below |
//! | `cylinder` (`r`, `h`; turn) | capped [`Cylinder`], radius 0.4, half height 0.5 | [-1, 1]³ | 0, inside below |
//! | `box-minus-sphere` (`h`, `r`; turn) | [`BoxMinusSphere`]: cube 0.55 minus a ball 0.5 on a corner | [-1, 1]³ | 0, inside below |
//! | `fandisk` (turn) | [`Fandisk`]: a box with a cylindrical groove and a chamfer | [-1, 1]³ | 0, inside below |
//! | `plates` (`count`, `t`, `gap`; turn) | [`Plates`]: 2 plates `t` = 0.3 cell widths thick, 0.4 apart | [-1, 1]³ | 0, inside below |
//! | `two-spheres` (`r`, `gap`) | [`TwoSpheres`] of radius 0.45, `gap` = 0.1 cell widths apart, the gap's middle on a lattice plane | [-1, 1]³ | 0, inside below |
//!
//! Every name takes `n` (points per axis, default 64, at least 2). The sharp CSG shapes (issue
//! 45; their exact corners and creases: [`BuiltinField::sharp_features`]) take a turn `ax`, `ay`, `az`, `angle`
//! (an axis and degrees; default 30° about (1, 2, 3), so that no corner or crease lies on a
//! lattice plane). The thickness of `plates` and the gap of `two-spheres` are in cell widths of
//! the field's `n`: they follow `n`.

use super::classic::{ChargeLines, ChargePoints, HeightField, CLASSIC_ISO};
use super::sdf::sharp::{default_rotation, Frame};
use super::sdf::{
    BoxMinusSphere, Cuboid, Cylinder, Fandisk, Features, Gyroid, Plates, RotatedBox, Sphere, Torus, TwoSpheres,
};
use super::{FieldVisitor, Iso};
use crate::error::{Error, Result};
use crate::grid::Lattice;
use crate::math::Vec3;

/// Names and one-line descriptions of the built-in fields.
pub const NAMES: [(&str, &str); 13] = [
    ("sphere", "signed distance to a sphere of radius r (0.7) in [-1,1]^3"),
    ("torus", "signed distance to a torus R (0.6), r (0.25) around z in [-1,1]^3"),
    ("box", "signed distance to a cube of half size h (0.6) in [-1,1]^3"),
    ("gyroid", "gyroid with `periods` (2) periods across [-1,1]^3, clipped to a ball of radius `clip` if given"),
    ("metaballs", "classic demo: charges around three moving points at time t (0.5), iso 48"),
    ("lines", "classic demo: charges around three moving lines at time t (0.5), iso 48"),
    ("height", "classic demo: radial height field, iso 48"),
    ("rotated-box", "box of half sizes hx, hy, hz (0.6, 0.45, 0.35), turned (ax, ay, az, angle: 30° about (1,2,3))"),
    ("cylinder", "capped cylinder of radius r (0.4), half height h (0.5), turned: two circular creases"),
    ("box-minus-sphere", "cube of half size h (0.55) minus a ball of radius r (0.5) on a corner, turned"),
    ("fandisk", "fandisk-like part: box, cylindrical groove, chamfer (convex and concave creases), turned"),
    ("plates", "count (2) parallel plates t (0.3) cell widths thick, gap (0.4) apart, turned"),
    ("two-spheres", "two balls of radius r (0.45), gap (0.1) cell widths apart"),
];

/// Default animation time of the classic fields: the three sources sit apart but their
/// surfaces still merge.
pub const DEFAULT_TIME: f32 = 0.5;

/// Default points per axis.
pub const DEFAULT_POINTS: u32 = 64;

/// A built-in field: the runtime choice, matched once by [`BuiltinField::visit`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum BuiltinField {
    /// See [`Sphere`].
    Sphere(Sphere),
    /// See [`Torus`].
    Torus(Torus),
    /// See [`Cuboid`].
    Cuboid(Cuboid),
    /// See [`Gyroid`].
    Gyroid(Gyroid),
    /// See [`ChargePoints`].
    ChargePoints(ChargePoints),
    /// See [`ChargeLines`].
    ChargeLines(ChargeLines),
    /// See [`HeightField`].
    HeightField(HeightField),
    /// See [`RotatedBox`].
    RotatedBox(RotatedBox),
    /// See [`Cylinder`].
    Cylinder(Cylinder),
    /// See [`BoxMinusSphere`].
    BoxMinusSphere(BoxMinusSphere),
    /// See [`Fandisk`].
    Fandisk(Fandisk),
    /// See [`Plates`].
    Plates(Plates),
    /// See [`TwoSpheres`].
    TwoSpheres(TwoSpheres),
}

impl BuiltinField {
    /// Calls `visitor` with the concrete field.
    pub fn visit<V: FieldVisitor>(&self, visitor: V) -> V::Output {
        match self {
            BuiltinField::Sphere(f) => visitor.visit(f),
            BuiltinField::Torus(f) => visitor.visit(f),
            BuiltinField::Cuboid(f) => visitor.visit(f),
            BuiltinField::Gyroid(f) => visitor.visit(f),
            BuiltinField::ChargePoints(f) => visitor.visit(f),
            BuiltinField::ChargeLines(f) => visitor.visit(f),
            BuiltinField::HeightField(f) => visitor.visit(f),
            BuiltinField::RotatedBox(f) => visitor.visit(f),
            BuiltinField::Cylinder(f) => visitor.visit(f),
            BuiltinField::BoxMinusSphere(f) => visitor.visit(f),
            BuiltinField::Fandisk(f) => visitor.visit(f),
            BuiltinField::Plates(f) => visitor.visit(f),
            BuiltinField::TwoSpheres(f) => visitor.visit(f),
        }
    }

    /// The exact corners and creases (sampled at most `spacing` apart) of the sharp CSG shapes;
    /// `None` for the other fields (smooth, or with no analytic features: `two-spheres` has
    /// none and gives empty [`Features`]).
    pub fn sharp_features(&self, spacing: f32) -> Option<Features> {
        Some(match self {
            BuiltinField::RotatedBox(f) => f.features(spacing),
            BuiltinField::Cylinder(f) => f.features(spacing),
            BuiltinField::BoxMinusSphere(f) => f.features(spacing),
            BuiltinField::Fandisk(f) => f.features(spacing),
            BuiltinField::Plates(f) => f.features(spacing),
            BuiltinField::TwoSpheres(_) => Features::default(),
            _ => return None,
        })
    }
}

/// A parsed built-in: the field, its lattice and its default iso.
#[derive(Debug, Clone, PartialEq)]
pub struct Builtin {
    /// The field.
    pub field: BuiltinField,
    /// The sampling lattice (domain and `n`).
    pub lattice: Lattice,
    /// The iso value and inside side the field is meant for.
    pub iso: Iso,
}

/// Parses `name` or `name?key=value&key=value`.
///
/// # Errors
/// [`Error::InvalidInput`] naming the unknown field, the unknown parameter or the bad value.
pub fn parse(spec: &str) -> Result<Builtin> {
    let (name, query) = spec.split_once('?').unwrap_or((spec, ""));
    let mut params: Vec<(&str, f64)> = Vec::new();
    for kv in query.split('&').filter(|s| !s.is_empty()) {
        let (k, v) = kv
            .split_once('=')
            .ok_or_else(|| Error::InvalidInput(format!("field:{spec}: parameter {kv:?} must be key=value")))?;
        let v: f64 =
            v.parse().ok().filter(|v: &f64| v.is_finite()).ok_or_else(|| {
                Error::InvalidInput(format!("field:{spec}: parameter {k}={v:?} is not a finite number"))
            })?;
        if params.iter().any(|(p, _)| *p == k) {
            return Err(Error::InvalidInput(format!("field:{spec}: parameter {k:?} given twice")));
        }
        params.push((k, v));
    }
    let allowed: &[&str] = match name {
        "sphere" => &["n", "r"],
        "torus" => &["n", "R", "r"],
        "box" => &["n", "h"],
        "gyroid" => &["n", "periods", "clip"],
        "metaballs" | "lines" => &["n", "t"],
        "height" => &["n"],
        "rotated-box" => &["n", "hx", "hy", "hz", "ax", "ay", "az", "angle"],
        "cylinder" | "box-minus-sphere" => &["n", "r", "h", "ax", "ay", "az", "angle"],
        "fandisk" => &["n", "ax", "ay", "az", "angle"],
        "plates" => &["n", "count", "t", "gap", "ax", "ay", "az", "angle"],
        "two-spheres" => &["n", "r", "gap"],
        _ => {
            let names: Vec<&str> = NAMES.iter().map(|(n, _)| *n).collect();
            return Err(Error::InvalidInput(format!("field:{name}: unknown field (known: {})", names.join(", "))));
        }
    };
    if let Some((k, _)) = params.iter().find(|(k, _)| !allowed.contains(k)) {
        return Err(Error::InvalidInput(format!(
            "field:{spec}: unknown parameter {k:?} for {name} (known: {})",
            allowed.join(", ")
        )));
    }
    let get = |k: &str, default: f64| params.iter().find(|(p, _)| *p == k).map_or(default, |p| p.1);
    let n = get("n", DEFAULT_POINTS as f64);
    if !((2.0..=4096.0).contains(&n) && n.fract() == 0.0) {
        return Err(Error::InvalidInput(format!("field:{spec}: n={n} must be a whole number from 2 to 4096")));
    }
    let n = n as u32;
    let positive = |k: &str, default: f64| -> Result<f32> {
        let v = get(k, default);
        if v > 0.0 {
            Ok(v as f32)
        } else {
            Err(Error::InvalidInput(format!("field:{spec}: {k}={v} must be positive")))
        }
    };
    let centered = |dims| Lattice::spanning(dims, [-1.0; 3], [1.0; 3]);
    let dims = [n; 3];
    let below0 = Iso::below(0.0);
    let cell = 2.0 / (n - 1) as f32;
    let frame = || -> Result<Frame> {
        let given = ["ax", "ay", "az", "angle"].iter().any(|k| params.iter().any(|(p, _)| p == k));
        if !given {
            return Ok(Frame { center: Vec3::ZERO, rotation: default_rotation() });
        }
        let axis = Vec3::new(get("ax", 1.0) as f32, get("ay", 2.0) as f32, get("az", 3.0) as f32);
        if axis.length() == 0.0 || !axis.is_finite() {
            return Err(Error::InvalidInput(format!("field:{spec}: the turn's axis (ax, ay, az) must not be zero")));
        }
        let angle = (get("angle", 30.0) as f32).to_radians();
        Ok(Frame { center: Vec3::ZERO, rotation: glam::Mat3::from_axis_angle(axis.normalize(), angle) })
    };
    let sharp = |field| Ok::<_, Error>(Builtin { field, lattice: centered(dims)?, iso: below0 });
    Ok(match name {
        "sphere" => Builtin {
            field: BuiltinField::Sphere(Sphere { center: Vec3::ZERO, radius: positive("r", 0.7)? }),
            lattice: centered(dims)?,
            iso: below0,
        },
        "torus" => Builtin {
            field: BuiltinField::Torus(Torus {
                center: Vec3::ZERO,
                major: positive("R", 0.6)?,
                minor: positive("r", 0.25)?,
            }),
            lattice: centered(dims)?,
            iso: below0,
        },
        "box" => Builtin {
            field: BuiltinField::Cuboid(Cuboid { center: Vec3::ZERO, half: Vec3::splat(positive("h", 0.6)?) }),
            lattice: centered(dims)?,
            iso: below0,
        },
        "gyroid" => Builtin {
            // `periods` full periods across the 2-unit domain.
            field: BuiltinField::Gyroid(Gyroid {
                frequency: std::f32::consts::PI * positive("periods", 2.0)?,
                clip: params.iter().any(|(k, _)| *k == "clip").then(|| positive("clip", 1.0)).transpose()?,
            }),
            lattice: centered(dims)?,
            iso: below0,
        },
        "rotated-box" => sharp(BuiltinField::RotatedBox(RotatedBox {
            frame: frame()?,
            half: Vec3::new(positive("hx", 0.6)?, positive("hy", 0.45)?, positive("hz", 0.35)?),
        }))?,
        "cylinder" => sharp(BuiltinField::Cylinder(Cylinder {
            frame: frame()?,
            radius: positive("r", 0.4)?,
            half_height: positive("h", 0.5)?,
        }))?,
        "box-minus-sphere" => {
            let (half, radius) = (positive("h", 0.55)?, positive("r", 0.5)?);
            if radius >= 2.0 * half {
                return Err(Error::InvalidInput(format!("field:{spec}: r={radius} must be below 2·h={}", 2.0 * half)));
            }
            sharp(BuiltinField::BoxMinusSphere(BoxMinusSphere { frame: frame()?, half, radius }))?
        }
        "fandisk" => sharp(BuiltinField::Fandisk(Fandisk { frame: frame()? }))?,
        "plates" => {
            let count = get("count", 2.0);
            if !((1.0..=Plates::MAX as f64).contains(&count) && count.fract() == 0.0) {
                return Err(Error::InvalidInput(format!(
                    "field:{spec}: count={count} must be a whole number from 1 to {}",
                    Plates::MAX
                )));
            }
            let (thickness, gap) = (positive("t", 0.3)? * cell, positive("gap", 0.4)?);
            if gap <= thickness {
                return Err(Error::InvalidInput(format!(
                    "field:{spec}: gap={gap} must exceed the thickness {thickness} (t cell widths)"
                )));
            }
            sharp(BuiltinField::Plates(Plates { frame: frame()?, count: count as u32, thickness, gap }))?
        }
        "two-spheres" => {
            // The gap's middle on the lattice plane x = -1 + ⌊(n-1)/2⌋·cell: the point there is
            // outside (gap/2 from both balls), so the balls' sign grids stay apart.
            let mid = -1.0 + ((n - 1) / 2) as f32 * cell;
            let radius = positive("r", 0.45)?;
            let gap = positive("gap", 0.1)? * cell;
            if 2.0 * radius + gap / 2.0 + mid.abs() >= 1.0 {
                return Err(Error::InvalidInput(format!("field:{spec}: r={radius} does not fit in [-1,1]")));
            }
            sharp(BuiltinField::TwoSpheres(TwoSpheres { mid, radius, gap }))?
        }
        "metaballs" => Classic::Metaballs.builtin(n, get("t", DEFAULT_TIME as f64) as f32)?,
        "lines" => Classic::Lines.builtin(n, get("t", DEFAULT_TIME as f64) as f32)?,
        _ => Classic::Height.builtin(n, DEFAULT_TIME)?,
    })
}

/// The classic demo's three fields: the typed form of `metaballs`, `lines` and `height`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Classic {
    /// [`ChargePoints`].
    Metaballs,
    /// [`ChargeLines`].
    Lines,
    /// [`HeightField`] (does not move).
    Height,
}

impl Classic {
    /// All three, in the demo's order.
    pub const ALL: [Classic; 3] = [Classic::Metaballs, Classic::Lines, Classic::Height];

    /// The catalogue name.
    pub fn name(self) -> &'static str {
        match self {
            Classic::Metaballs => "metaballs",
            Classic::Lines => "lines",
            Classic::Height => "height",
        }
    }

    /// Parses a catalogue name.
    pub fn parse(s: &str) -> Option<Classic> {
        Classic::ALL.into_iter().find(|c| c.name() == s)
    }

    /// The field at animation time `t` (ignored by the height field) on the unit cube with `n`
    /// points per axis, with the demo's iso.
    ///
    /// # Errors
    /// As [`Lattice::spanning`] (`n` below 2 or too large).
    pub fn builtin(self, n: u32, t: f32) -> Result<Builtin> {
        let lattice = Lattice::spanning([n; 3], [0.0; 3], [1.0; 3])?;
        Ok(match self {
            Classic::Metaballs => Builtin {
                field: BuiltinField::ChargePoints(ChargePoints::at_time(t)),
                lattice,
                iso: Iso::above(CLASSIC_ISO),
            },
            Classic::Lines => Builtin {
                field: BuiltinField::ChargeLines(ChargeLines::at_time(t)),
                lattice,
                iso: Iso::above(CLASSIC_ISO),
            },
            Classic::Height => Builtin {
                field: BuiltinField::HeightField(HeightField::default()),
                lattice,
                iso: Iso::below(CLASSIC_ISO),
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn issue_50_a_parameter_given_twice_is_an_error() {
        let e = parse("gyroid?n=64&n=128").unwrap_err().to_string();
        assert!(e.contains("parameter \"n\" given twice"), "{e}");
        assert!(parse("gyroid?n=64&periods=2").is_ok());
    }

    #[test]
    fn parses_names_and_parameters() {
        let b = parse("gyroid?n=32&periods=3").unwrap();
        assert_eq!(b.lattice.dims(), [32; 3]);
        assert!(matches!(b.field, BuiltinField::Gyroid(_)));
        for (name, _) in NAMES {
            assert!(parse(name).is_ok(), "{name}");
        }
    }

    #[test]
    fn classic_fields_equal_their_specs() {
        for (c, spec) in [
            (Classic::Metaballs, "metaballs?n=24&t=0.25"),
            (Classic::Lines, "lines?n=24&t=0.25"),
            (Classic::Height, "height?n=24"),
        ] {
            assert_eq!(Classic::parse(c.name()), Some(c));
            assert_eq!(c.builtin(24, 0.25).unwrap(), parse(spec).unwrap(), "{spec}");
        }
        assert_eq!(Classic::parse("sphere"), None);
        assert!(Classic::Metaballs.builtin(1, 0.5).is_err());
    }

    #[test]
    fn rejects_bad_specs() {
        for bad in [
            "plates?count=9",
            "plates?t=2000",
            "two-spheres?r=0.6",
            "rotated-box?ax=0&ay=0&az=0",
            "box-minus-sphere?r=2",
            "nope",
            "sphere?n=1",
            "sphere?n=2.5",
            "sphere?r=-1",
            "sphere?q=1",
            "sphere?n",
            "sphere?n=nan",
        ] {
            let e = parse(bad).unwrap_err().to_string();
            assert!(e.contains("field:"), "{bad}: {e}");
        }
    }
}
