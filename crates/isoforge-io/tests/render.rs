//! `render` against a golden picture (tolerance for last-bit differences between machines).
//! `ISOFORGE_BLESS=1 cargo test -p isoforge-io --test render` rewrites it; look at it first.

use std::path::PathBuf;

use isoforge::pipeline::{extract, Method, Options};
use isoforge::volume::{catalog, Iso, Sampled};
use isoforge_io::render::{render, RenderOptions, Shading, View};

fn golden() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../testdata/golden/render_torus_open.png")
}

fn scene() -> (Vec<u8>, [u32; 2]) {
    // A torus cut by the lattice's top face: closed around, open (red edges) on top.
    let b = catalog::parse("torus?n=20").unwrap();
    let mut lattice = b.lattice.clone();
    let dims = lattice.dims();
    lattice = lattice.with_dims([dims[0], dims[1], dims[2] * 3 / 5]).unwrap();
    let mesh = match &b.field {
        catalog::BuiltinField::Torus(t) => {
            extract(
                &Sampled::new(*t, lattice),
                Iso::below(0.0),
                &Options { method: Method::MarchingCubes, ..Default::default() },
            )
            .unwrap()
            .mesh
        }
        _ => unreachable!("parsed a torus"),
    };
    let size = [96, 72];
    let opts = RenderOptions { size, view: View::Iso, shading: Shading::Lambert, wireframe: true, defects: true };
    (render(&mesh, None, &opts), size)
}

#[test]
fn render_matches_the_golden_picture() {
    let (img, size) = scene();
    if std::env::var_os("ISOFORGE_BLESS").is_some() {
        let mut f = std::fs::File::create(golden()).unwrap();
        isoforge_io::render::write_png(&mut f, &img, size).unwrap();
        return;
    }
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(golden()).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut want = vec![0u8; reader.output_buffer_size().unwrap()];
    reader.next_frame(&mut want).unwrap();
    assert_eq!(want.len(), img.len());
    let diffs: Vec<u8> = img.iter().zip(&want).map(|(a, b)| a.abs_diff(*b)).collect();
    let mean = diffs.iter().map(|&d| d as f64).sum::<f64>() / diffs.len() as f64;
    let large = diffs.chunks(3).filter(|p| p.iter().any(|&d| d > 40)).count();
    assert!(mean < 1.0 && large * 200 < diffs.len() / 3, "picture differs: mean {mean:.2}, {large} pixels far off");
    // The picture shows something: shaded surface, wireframe and red boundary pixels.
    let red = img.chunks(3).filter(|p| p[0] > 180 && p[1] < 60 && p[2] < 60).count();
    let background = img.chunks(3).filter(|p| p == &[250, 250, 250]).count();
    assert!(red > 20, "no boundary drawn ({red} red pixels)");
    assert!(background > 1000 && background < 96 * 72 - 1000, "{background} background pixels");
}
