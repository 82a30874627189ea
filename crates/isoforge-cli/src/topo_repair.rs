//! `isoforge topo-repair`: read a solid (SOG, mesh or volume), repair its topology in the
//! library (`isoforge::mend`), write the surface (and the skeletons, the grid), report.

use std::time::Instant;

use anyhow::{anyhow, Result};
use isoforge::grid::{AnyGrid, DenseGrid, SignedOctree};
use isoforge::mend::{self, Operation, RepairReport};
use isoforge::mesh::Mesh;
use isoforge::pipeline::{self, Options};
use isoforge::topo::{self, MeshReport};
use isoforge::volume::{GridVolume, Iso};
use isoforge::voxelize::{self, Resolution, VoxelizeOptions};
use isoforge_io::VolumeFormat;
use serde_json::{json, Value};

use crate::config::{SolidInput, TopoRepairConfig};
use crate::progress::spin;
use crate::run::Outcome;

/// The solid as a grid of `f32` values at its iso, and the tree it came from (a SOG input).
fn solid(c: &TopoRepairConfig) -> Result<(DenseGrid<f32>, Option<SignedOctree>)> {
    let name = c.input.display().to_string();
    let with_name = |e: isoforge::Error| anyhow!("{name}: {e}");
    Ok(match c.kind {
        SolidInput::Sog => {
            let tree = spin(format!("reading {name}"), || isoforge_io::read_sog(&c.input, &c.limits))?;
            // The repair's size limit from the tree alone, before its dense sign grid is built.
            if let Some((lo, hi)) = tree.inside_box() {
                mend::complex_box(lo.map(i64::from), hi.map(i64::from)).map_err(with_name)?;
            }
            // Signs as −1 inside and +3 outside: MC33 then has the cell complex's topology
            // (TopoMender's), which ±1 does not (isoforge::mend::sign_like).
            let mut g = tree.to_sign_grid().map_err(with_name)?;
            g.data_mut().iter_mut().for_each(|v| *v = mend::sign_like(c.iso, *v < 0.0, 1.0));
            (g, Some(tree))
        }
        SolidInput::Mesh(cells) => {
            let mesh = spin(format!("reading {name}"), || isoforge_io::read_mesh(&c.input, &c.limits))?;
            let opts = VoxelizeOptions { max_bytes: c.limits.max_bytes, ..VoxelizeOptions::default() };
            let lattice = voxelize::lattice_for(&mesh, Resolution::Cells(cells), opts.band.ceil() as u32 + 1)
                .map_err(with_name)?;
            let v =
                spin(format!("voxelizing {name}"), || voxelize::voxelize(&mesh, lattice, &opts)).map_err(with_name)?;
            match v.to_dense(voxelize::Output::Sdf, c.limits.max_bytes).map_err(with_name)? {
                AnyGrid::F32(g) => (g, None),
                _ => unreachable!("signed distances are f32"),
            }
        }
        SolidInput::Volume => {
            let g = spin(format!("reading {name}"), || isoforge_io::read_volume(&c.input, &c.limits))?;
            (to_f32(g).map_err(with_name)?, None)
        }
    })
}

/// A grid of any sample type as `f32` (exact for 8- and 16-bit samples).
fn to_f32(g: AnyGrid) -> isoforge::Result<DenseGrid<f32>> {
    if let AnyGrid::F32(g) = g {
        return Ok(g);
    }
    let lattice = g.lattice().clone();
    DenseGrid::new(lattice, g.values_f64().map(|v| v as f32).collect())
}

fn surface(grid: &DenseGrid<f32>, iso: Iso) -> Result<(Mesh, MeshReport)> {
    let out = pipeline::extract(&GridVolume::new(grid), iso, &Options::default())?;
    let rep = topo::check(&out.mesh);
    Ok((out.mesh, rep))
}

fn op_json(o: &Operation) -> Value {
    json!({ "size": o.size, "at": o.at, "performed": o.performed, "points_changed": o.points_changed })
}

fn summary(
    c: &TopoRepairConfig,
    r: &RepairReport,
    before: &MeshReport,
    after: &MeshReport,
    points: u64,
    seconds: f64,
) -> Value {
    let ops = |v: &[Operation], done: bool| v.iter().filter(|o| o.performed == done).map(op_json).collect::<Vec<_>>();
    json!({
        "input": c.input.display().to_string(),
        "output": c.output.display().to_string(),
        "thin": c.options.thin, "grow": c.options.grow,
        "genus_before": before.genus(), "genus_after": after.genus(),
        "components_before": before.components.len(), "components_after": after.components.len(),
        "handles_found": r.handles.len(), "tunnels_found": r.tunnels.len(),
        "cuts": ops(&r.handles, true), "fills": ops(&r.tunnels, true),
        "handles_kept": ops(&r.handles, false), "tunnels_kept": ops(&r.tunnels, false),
        "points_changed": r.points_changed, "fraction_changed": r.points_changed as f64 / points.max(1) as f64,
        "box_points": r.box_points, "thinning_rounds": r.rounds, "stuck_elements": r.stuck, "repair_seconds": seconds,
        "closed": after.is_closed(), "manifold": after.is_manifold(), "oriented": after.is_oriented(),
    })
}

fn text(j: &Value) -> String {
    let mut s = String::new();
    let line = |s: &mut String, k: &str, v: String| s.push_str(&format!("{k:<16}{v}\n"));
    line(&mut s, "input:", j["input"].as_str().unwrap_or("").to_string());
    line(&mut s, "output:", j["output"].as_str().unwrap_or("").to_string());
    line(&mut s, "genus:", format!("{} before, {} after", j["genus_before"], j["genus_after"]));
    line(&mut s, "components:", format!("{} before, {} after", j["components_before"], j["components_after"]));
    for (kind, done, kept, verb) in
        [("handles:", "cuts", "handles_kept", "cut"), ("tunnels:", "fills", "tunnels_kept", "filled")]
    {
        let list = |k: &str| j[k].as_array().cloned().unwrap_or_default();
        let (d, k) = (list(done), list(kept));
        let sizes = |v: &[Value]| {
            v.iter().map(|o| format!("{:.6}", o["size"].as_f64().unwrap_or(0.0))).collect::<Vec<_>>().join(", ")
        };
        line(
            &mut s,
            kind,
            format!(
                "{} found; {} {verb} (sizes {}); {} kept (sizes {})",
                d.len() + k.len(),
                d.len(),
                sizes(&d),
                k.len(),
                sizes(&k)
            ),
        );
    }
    line(
        &mut s,
        "points changed:",
        format!("{} ({:.5} % of the grid)", j["points_changed"], 100.0 * j["fraction_changed"].as_f64().unwrap_or(0.0)),
    );
    if j["stuck_elements"].as_array().is_some_and(|v| v.iter().any(|x| x.as_u64() != Some(0))) {
        line(
            &mut s,
            "note:",
            format!(
                "thinning stopped at {} faces/cells (solid, outside): sheets (a knotted shape's outside \
                 needs them); their loops were found by reduction over their faces",
                j["stuck_elements"]
            ),
        );
    }
    line(&mut s, "surface:", format!("closed {}, manifold {}, oriented {}", j["closed"], j["manifold"], j["oriented"]));
    line(&mut s, "time:", format!("{:.3} s repairing", j["repair_seconds"].as_f64().unwrap_or(0.0)));
    s
}

pub fn topo_repair(c: &TopoRepairConfig) -> Result<Outcome> {
    let batch = crate::outputs::plan_one(&c.output, "-o", Some(c.format), None, Some(&c.input))?;
    for (p, role) in [(&c.skeleton, "--skeleton"), (&c.grid_out, "--grid-out")] {
        if let Some(p) = p {
            batch.reserve(p, role)?;
        }
    }
    batch.refuse_inputs(&[(c.input.clone(), String::new())])?;
    let (mut grid, tree) = solid(c)?;
    let (_, before) = spin("extracting the surface as it is", || surface(&grid, c.iso))?;
    let start = Instant::now();
    let report = spin("thinning, finding handles and tunnels", || {
        mend::repair(&mut grid, c.iso, &c.options, c.skeleton.is_some())
    })
    .map_err(|e| anyhow!("{}: {e}", c.input.display()))?;
    let seconds = start.elapsed().as_secs_f64();
    let (mesh, after) = spin("extracting the repaired surface", || surface(&grid, c.iso))?;
    let name = c.output.display().to_string();
    spin(format!("writing {name}"), || batch.write_mesh(&c.output, &mesh, &Default::default(), c.format))?;
    if let Some(p) = &c.skeleton {
        let cells = grid.lattice().dims().iter().map(|&d| d.saturating_sub(1)).max().unwrap_or(1).max(1);
        let depth = tree.as_ref().map_or(cells.next_power_of_two().trailing_zeros(), |t| t.depth());
        batch.write_skt(p, &report.skeleton, depth)?;
    }
    if let Some(p) = &c.grid_out {
        if VolumeFormat::from_path(p) == Some(VolumeFormat::Sog) {
            let iso = c.iso;
            let t =
                SignedOctree::from_values(grid.lattice(), &|ijk| iso.offset(f64::from(grid.get(ijk))), tree.as_ref())
                    .map_err(|e| anyhow!("{}: {e}", p.display()))?;
            batch.write_sog(p, &t)?;
        } else {
            batch.write_volume(p, &AnyGrid::F32(grid.clone()))?;
        }
    }
    batch.commit()?;
    let j = summary(c, &report, &before, &after, grid.lattice().num_points(), seconds);
    if c.json {
        println!("{}", serde_json::to_string_pretty(&j)?);
    } else {
        print!("{}", text(&j));
    }
    Ok(if after.is_watertight() { Outcome::Success } else { Outcome::CheckFailed })
}
