//! Embeds the viewer's built assets (`viewer/dist`, made by `npm ci && npm run build` in
//! `viewer/`) into the binary. When they are absent the list is empty and `isoforge view`
//! serves a page explaining how to build them; `cargo build` never needs Node.

use std::path::{Path, PathBuf};

fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            files(&p, out);
        } else {
            out.push(p);
        }
    }
}

fn mime(p: &Path) -> &'static str {
    match p.extension().and_then(|e| e.to_str()).unwrap_or("") {
        "html" => "text/html; charset=utf-8",
        "js" | "mjs" => "text/javascript; charset=utf-8",
        "css" => "text/css; charset=utf-8",
        "json" | "map" => "application/json",
        "svg" => "image/svg+xml",
        "png" => "image/png",
        _ => "application/octet-stream",
    }
}

fn main() {
    let dist = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../viewer/dist");
    println!("cargo:rerun-if-changed={}", dist.display());
    let mut list = Vec::new();
    files(&dist, &mut list);
    list.sort();
    let mut code = String::from(
        "/// (path, bytes, MIME type) of each embedded viewer file.\npub static ASSETS: &[(&str, &[u8], &str)] = &[\n",
    );
    for p in &list {
        let rel = p.strip_prefix(&dist).unwrap_or(p).to_string_lossy().replace('\\', "/");
        println!("cargo:rerun-if-changed={}", p.display());
        code.push_str(&format!("    ({rel:?}, include_bytes!({:?}), {:?}),\n", p.display().to_string(), mime(p)));
    }
    code.push_str("];\n");
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets OUT_DIR")).join("assets.rs");
    std::fs::write(out, code).expect("write assets.rs");
}
