//! `isoforge voxelize` and `isoforge repair`: read a mesh, voxelize it in the library, write the
//! volume, or extract and write the repaired mesh with its report.

use std::time::Instant;

use anyhow::Result;
use isoforge::pipeline::{self, Options};
use isoforge::topo::{self, CheckOptions};
use isoforge::volume::Iso;
use isoforge::voxelize::{self, VoxelizeOptions, Voxelized};
use isoforge_io::{GridClass, VdbWriteOptions};
use serde_json::{json, Value};

use crate::config::{RepairConfig, VoxelConfig, VoxelizeConfig};
use crate::progress::spin;
use crate::report;
use crate::run::Outcome;

/// Reads the mesh and voxelizes it; the seconds spent voxelizing.
/// With `octree`, the lattice is a cube of 2^depth cells (the resolution rounded up to a power
/// of two), as a signed octree needs.
fn voxelized(c: &VoxelConfig, octree: bool) -> Result<(isoforge::mesh::Mesh, Voxelized, f64)> {
    let name = c.mesh.display().to_string();
    let mesh = spin(format!("reading {name}"), || isoforge_io::read_mesh(&c.mesh, &c.limits))?;
    let with_name = |e: isoforge::Error| anyhow::anyhow!("{name}: {e}");
    // Room for the band and one more cell, so the surface never meets the lattice's faces.
    let margin = c.band.ceil() as u32 + 1;
    let lattice = match c.resolution.cells() {
        Some(n) if octree => {
            let depth = n.next_power_of_two().trailing_zeros().max(margin.next_power_of_two().trailing_zeros() + 2);
            voxelize::lattice_for_octree(&mesh, depth, margin)
        }
        _ => voxelize::lattice_for(&mesh, c.resolution, margin),
    }
    .map_err(with_name)?;
    let opts = VoxelizeOptions { band: c.band, max_bytes: c.limits.max_bytes };
    let start = Instant::now();
    let d = lattice.dims();
    let v = spin(format!("voxelizing {name} on {} x {} x {} points", d[0], d[1], d[2]), || {
        voxelize::voxelize(&mesh, lattice, &opts)
    })
    .map_err(with_name)?;
    Ok((mesh, v, start.elapsed().as_secs_f64()))
}

/// The lattice and the repairs, as JSON.
fn summary(v: &Voxelized, seconds: f64) -> Value {
    let l = v.grid.lattice();
    let r = &v.repairs;
    json!({
        "dims": l.dims(), "spacing": l.spacing()[0], "origin": l.origin(),
        "leaves": v.grid.num_leaves(), "voxelize_seconds": seconds,
        "repairs": {
            "welded_vertices": r.welded_vertices, "duplicate_faces": r.duplicate_faces,
            "degenerate_faces": r.degenerate_faces, "flipped_faces": r.flipped_faces,
            "patches": r.patches, "nested_patches": r.nested_patches,
        },
    })
}

fn summary_text(v: &Voxelized, seconds: f64) -> String {
    let l = v.grid.lattice();
    let (d, r) = (l.dims(), &v.repairs);
    format!(
        "lattice:     {} x {} x {} points, spacing {:.6}, {} leaves of 8³ in the band ({seconds:.3} s)\n\
         repairs:     {} vertices welded, {} duplicate and {} degenerate faces dropped, {} faces flipped, \
         {} patches ({} nested, reversed)\n",
        d[0],
        d[1],
        d[2],
        l.spacing()[0],
        v.grid.num_leaves(),
        r.welded_vertices,
        r.duplicate_faces,
        r.degenerate_faces,
        r.flipped_faces,
        r.patches,
        r.nested_patches
    )
}

pub fn voxelize(c: &VoxelizeConfig) -> Result<Outcome> {
    let batch = crate::outputs::plan_one(&c.output, "-o", None, None, Some(&c.voxel.mesh))?;
    let (_, v, seconds) = voxelized(&c.voxel, c.octree)?;
    let out = c.output.display().to_string();
    if c.sparse {
        let opts = VdbWriteOptions {
            name: "surface".into(),
            class: GridClass::LevelSet,
            value_type: isoforge_io::read::vdb::VdbValueType::Float,
        };
        spin(format!("writing {out}"), || batch.write_sparse(&c.output, &v.grid, &opts))?;
    } else if c.octree {
        let tree =
            spin("building the signed octree", || v.to_signed_octree()).map_err(|e| anyhow::anyhow!("{out}: {e}"))?;
        spin(format!("writing {out}"), || batch.write_sog(&c.output, &tree))?;
    } else {
        let dense = v.to_dense(c.values, c.voxel.limits.max_bytes).map_err(|e| anyhow::anyhow!("{out}: {e}"))?;
        spin(format!("writing {out}"), || batch.write_volume(&c.output, &dense))?;
    }
    batch.commit()?;
    if c.voxel.json {
        let mut j = summary(&v, seconds);
        j["input"] = json!(c.voxel.mesh.display().to_string());
        j["output"] = json!(out);
        println!("{}", serde_json::to_string_pretty(&j)?);
    } else {
        println!("output:      {out}");
        print!("{}", summary_text(&v, seconds));
    }
    Ok(Outcome::Success)
}

pub fn repair(c: &RepairConfig) -> Result<Outcome> {
    let batch = crate::outputs::plan_one(&c.output, "-o", Some(c.format), None, Some(&c.voxel.mesh))?;
    let (input, v, seconds) = voxelized(&c.voxel, false)?;
    let start = Instant::now();
    let out = spin("extracting the repaired surface", || {
        pipeline::extract_sparse(&v.grid, Iso::below(0.0), &Options::default())
    })?;
    let extract_seconds = start.elapsed().as_secs_f64();
    let name = c.output.display().to_string();
    spin(format!("writing {name}"), || batch.write_mesh(&c.output, &out.mesh, &Default::default(), c.format))?;
    batch.commit()?;
    let rep = topo::check_with(&out.mesh, &CheckOptions::default());
    let h = spin("measuring the distance to the input", || topo::hausdorff(&out.mesh, &input));
    if c.voxel.json {
        let mut j = report::mesh_json(&rep);
        j["voxelize"] = summary(&v, seconds);
        j["extract_seconds"] = json!(extract_seconds);
        j["hausdorff"] = json!({ "to_input": h.forward, "from_input": h.backward, "mean": h.mean });
        j["input"] = json!(c.voxel.mesh.display().to_string());
        j["output"] = json!(name);
        println!("{}", serde_json::to_string_pretty(&j)?);
    } else {
        println!("output:      {name}");
        print!("{}", summary_text(&v, seconds));
        println!(
            "hausdorff:   {:.6} from the output's vertices to the input, {:.6} from the input's (mean {:.6}; spacing {:.6})",
            h.forward,
            h.backward,
            h.mean,
            v.grid.lattice().spacing()[0]
        );
        print!("{}", report::mesh_text(&rep));
    }
    Ok(if rep.is_watertight() { Outcome::Success } else { Outcome::CheckFailed })
}
