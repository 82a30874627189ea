//! Isolines (marching squares) as SVG, GeoJSON or CSV, in the coordinates of a [`ContourFrame`]:
//! pixel indices by default (x = column, y = row, as in the image: SVG's y axis points down like
//! the rows), or placed by an origin and a spacing.

use std::io::{self, Write};
use std::path::Path;

use isoforge::extract::Polyline;

/// A contour file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ContourFormat {
    /// SVG: one `<path>` per contour (closed ones end with `Z`), the image box as view box.
    Svg,
    /// GeoJSON: a FeatureCollection of LineStrings (closed rings repeat their first point), with
    /// `level`, `closed` and `length` properties.
    GeoJson,
    /// CSV: `contour,point,x,y,closed`.
    Csv,
}

impl ContourFormat {
    /// The format a path's extension names (.svg, .geojson / .json, .csv).
    pub fn from_path(path: &Path) -> Option<Self> {
        let n = path.file_name()?.to_string_lossy().to_ascii_lowercase();
        let ext = n.rsplit_once('.')?.1.to_string();
        Some(match ext.as_str() {
            "svg" => ContourFormat::Svg,
            "geojson" | "json" => ContourFormat::GeoJson,
            "csv" => ContourFormat::Csv,
            _ => return None,
        })
    }
}

/// Where an image's pixels lie in the written coordinates: pixel `(i, j)` at
/// `origin + (i, j) · spacing`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContourFrame {
    /// Pixels per axis.
    pub dims: [u32; 2],
    /// Position of pixel (0, 0).
    pub origin: [f64; 2],
    /// Distance between pixel centres along x and y (positive).
    pub spacing: [f64; 2],
}

impl ContourFrame {
    /// Pixel-index coordinates (origin 0, spacing 1).
    pub fn pixels(dims: [u32; 2]) -> Self {
        ContourFrame { dims, origin: [0.0; 2], spacing: [1.0; 2] }
    }

    /// A contour in pixel coordinates (as marching squares gives it), placed in this frame.
    pub fn place(&self, line: &Polyline) -> Polyline {
        let points = line.points.iter().map(|p| [0, 1].map(|a| self.origin[a] + p[a] * self.spacing[a])).collect();
        Polyline { points, closed: line.closed }
    }
}

/// Writes `lines` (in `frame`'s coordinates) of an image at `level`.
pub fn write_contours(
    w: &mut dyn Write,
    lines: &[Polyline],
    format: ContourFormat,
    frame: &ContourFrame,
    level: f64,
) -> io::Result<()> {
    match format {
        ContourFormat::Svg => {
            let [nx, ny] = frame.dims.map(|d| d.saturating_sub(1).max(1));
            let [sx, sy] = frame.spacing;
            let [ox, oy] = frame.origin;
            let (bw, bh) = (nx as f64 * sx, ny as f64 * sy);
            let width = nx.max(256);
            writeln!(w, r#"<?xml version="1.0" encoding="UTF-8"?>"#)?;
            writeln!(
                w,
                r#"<svg xmlns="http://www.w3.org/2000/svg" viewBox="{ox} {oy} {bw} {bh}" width="{width}" height="{}">"#,
                (bh * width as f64 / bw) as u64
            )?;
            writeln!(
                w,
                r#"<g fill="none" stroke="black" stroke-width="{}">"#,
                (bw.max(bh) / 400.0).max(0.05 * sx.min(sy))
            )?;
            for l in lines {
                write!(w, r#"<path d=""#)?;
                for (k, p) in l.points.iter().enumerate() {
                    write!(w, "{}{} {}", if k == 0 { "M" } else { " L" }, p[0], p[1])?;
                }
                writeln!(w, r#"{}"/>"#, if l.closed { " Z" } else { "" })?;
            }
            writeln!(w, "</g>\n</svg>")
        }
        ContourFormat::GeoJson => {
            write!(w, r#"{{"type":"FeatureCollection","features":["#)?;
            for (k, l) in lines.iter().enumerate() {
                if k > 0 {
                    write!(w, ",")?;
                }
                write!(w, r#"{{"type":"Feature","geometry":{{"type":"LineString","coordinates":["#)?;
                let ring = l.points.iter().chain(if l.closed { l.points.first() } else { None });
                for (i, p) in ring.enumerate() {
                    write!(w, "{}[{},{}]", if i == 0 { "" } else { "," }, p[0], p[1])?;
                }
                write!(w, r#"]}},"properties":{{"level":{level},"closed":{},"length":{}}}}}"#, l.closed, l.length())?;
            }
            writeln!(w, "]}}")
        }
        ContourFormat::Csv => {
            writeln!(w, "contour,point,x,y,closed")?;
            for (k, l) in lines.iter().enumerate() {
                for (i, p) in l.points.iter().enumerate() {
                    writeln!(w, "{k},{i},{},{},{}", p[0], p[1], l.closed)?;
                }
            }
            Ok(())
        }
    }
}

/// [`write_contours`] to a file, atomically (temporary file, then rename).
///
/// # Errors
/// [`Error::Io`](crate::Error::Io) when the file cannot be written.
pub fn write_contour_file(
    path: &Path,
    lines: &[Polyline],
    format: ContourFormat,
    frame: &ContourFrame,
    level: f64,
) -> crate::Result<()> {
    crate::write_atomic(path, |w| write_contours(w, lines, format, frame, level))
}
