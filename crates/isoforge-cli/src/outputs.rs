//! Output planning: before any work, every file a command will write is checked (its folder
//! exists and is writable, it is not a folder, it is not one of the command's inputs, no two
//! outputs are the same file) and its temporary file created; the command then fills the
//! [`Batch`] and commits it at the end, so all outputs appear together or none does.

use std::path::{Path, PathBuf};

use anyhow::{bail, Result};
use isoforge::pipeline::request::AttributeSource;
use isoforge_io::{Batch, MeshFormat};

use crate::config::{ExtractConfig, InputConfig, Source};

/// The files an input reads, labelled by the flag that named them.
fn input_files(input: &InputConfig, role: &str) -> Vec<(PathBuf, String)> {
    match &input.source {
        Source::File { path, .. } => {
            isoforge_io::input_files(path).into_iter().map(|p| (p, role.to_string())).collect()
        }
        Source::Field(_) => Vec::new(),
    }
}

/// A batch holding `outputs` (path, format or `None` for a plain file, role), refusing first
/// any file they would write that is one of `inputs`.
fn plan(outputs: &[(PathBuf, Option<MeshFormat>, String)], inputs: &[(PathBuf, String)]) -> Result<Batch> {
    let files: Vec<(PathBuf, String)> = outputs
        .iter()
        .flat_map(|(path, format, role)| match format {
            Some(f) => f.outputs(path, role),
            None => vec![(path.clone(), role.clone())],
        })
        .collect();
    isoforge_io::refuse_overwrite(&files, inputs)?;
    let batch = Batch::new();
    for (path, format, role) in outputs {
        match format {
            Some(f) => batch.reserve_mesh(path, *f, role)?,
            None => batch.reserve(path, role)?,
        }
    }
    Ok(batch)
}

/// The mesh file and `--time-json` file of iso `index` (of `count`) of an `extract` run: one
/// file per iso (`out-300.ply`) unless the format holds several meshes (glTF, OBJ).
pub fn extract_paths(c: &ExtractConfig, iso: f64, count: usize) -> (PathBuf, Option<PathBuf>) {
    if count <= 1 || one_file_for_all_isos(c, count) {
        (c.output.clone(), c.time_json.clone())
    } else {
        (with_suffix(&c.output, iso), c.time_json.as_ref().map(|t| with_suffix(t, iso)))
    }
}

/// Whether several isos go into one file (glTF and OBJ hold one object per iso).
pub fn one_file_for_all_isos(c: &ExtractConfig, count: usize) -> bool {
    count > 1 && matches!(c.format, MeshFormat::Glb | MeshFormat::Gltf | MeshFormat::Obj)
}

/// `out.ply` → `out-300.ply` for iso 300.
fn with_suffix(path: &Path, iso: f64) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let (stem, ext) = match name.split_once('.') {
        Some((s, e)) => (s.to_string(), format!(".{e}")),
        None => (name.clone(), String::new()),
    };
    path.with_file_name(format!("{stem}-{iso}{ext}"))
}

/// The outputs of `extract`, reserved: the mesh file(s) (and a glTF's buffer), the
/// `--time-json` file(s); none may be an input (`-i` and its data files, `--mask`,
/// `--attribute` volumes, `--color-volume`).
pub fn plan_extract(c: &ExtractConfig) -> Result<Batch> {
    // Isos without values (a field's default) and labels write one file.
    let r = &c.request;
    let isos: Vec<f64> = if r.isos.is_empty() || r.labels.is_some() { vec![0.0] } else { r.isos.clone() };
    let mut outputs = Vec::new();
    for &iso in &isos {
        let (mesh, time) = extract_paths(c, iso, isos.len());
        if !outputs.iter().any(|(p, _, _)| *p == mesh) {
            outputs.push((mesh, Some(c.format), "-o".to_string()));
            if let Some(t) = time {
                outputs.push((t, None, "--time-json".to_string()));
            }
        }
    }
    if outputs.len() > isoforge_io::Batch::MAX_FILES {
        bail!(
            "--iso: {} values write {} files; at most {} in one run",
            isos.len(),
            outputs.len(),
            isoforge_io::Batch::MAX_FILES
        );
    }
    let mut inputs = input_files(&c.input, "-i");
    if let Some(m) = &c.mask {
        inputs.extend(input_files(m, "--mask"));
    }
    for (name, source) in &c.request.attributes {
        if let AttributeSource::Volume(v) = source {
            inputs.extend(input_files(v, &format!("--attribute {name}")));
        }
    }
    if let Some(v) = &c.color_volume {
        inputs.push((v.clone(), "--color-volume".to_string()));
    }
    plan(&outputs, &inputs)
}

/// One output file, named by `role` (`-o`, or "the output" when positional), that must not be
/// one of the files the (positional) input volume or mesh reads.
pub fn plan_one(
    output: &Path,
    role: &str,
    format: Option<MeshFormat>,
    input: Option<&InputConfig>,
    mesh: Option<&Path>,
) -> Result<Batch> {
    let mut inputs = input.map(|i| input_files(i, "")).unwrap_or_default();
    if let Some(m) = mesh {
        inputs.push((m.to_path_buf(), String::new()));
    }
    plan(&[(output.to_path_buf(), format, role.to_string())], &inputs)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn iso_suffixes_keep_the_extension() {
        assert_eq!(with_suffix(Path::new("d/out.ply"), 300.0), Path::new("d/out-300.ply"));
        assert_eq!(with_suffix(Path::new("out.nii.gz"), -1.5), Path::new("out--1.5.nii.gz"));
        assert_eq!(with_suffix(Path::new("out"), 2.0), Path::new("out-2"));
    }
}
