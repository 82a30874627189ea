//! Text and JSON renderings of mesh reports and volume summaries.

use isoforge::topo::{EdgeFinding, Findings, MeshReport};
use serde_json::{json, Value};

fn edge_json(f: &EdgeFinding) -> Value {
    json!({ "edge": f.edge, "faces": f.faces, "midpoint": f.midpoint, "cell": f.cell })
}

fn findings_json<T>(f: &Findings<T>, item: impl Fn(&T) -> Value) -> Value {
    json!({ "count": f.count, "examples": f.examples.iter().map(item).collect::<Vec<_>>() })
}

/// The report as JSON.
pub fn mesh_json(r: &MeshReport) -> Value {
    json!({
        "vertices": r.vertices,
        "triangles": r.triangles,
        "edges": r.edges,
        "closed": r.is_closed(),
        "edge_manifold": r.is_edge_manifold(),
        "manifold": r.is_manifold(),
        "oriented": r.is_oriented(),
        "watertight": r.is_watertight(),
        "euler": r.euler,
        "genus": r.genus(),
        "area": r.area,
        "volume": r.volume,
        "min_angle_mean_deg": r.min_angle_mean_deg,
        "min_angle_deg": r.min_angle_deg,
        "self_intersections": r.self_intersection_count(),
        "bounds": if r.bounds.is_empty() { Value::Null } else { json!({ "min": r.bounds.min, "max": r.bounds.max }) },
        "components": r.components.iter().map(|c| json!({
            "vertices": c.vertices, "edges": c.edges, "triangles": c.triangles, "euler": c.euler,
            "closed": c.closed, "genus": c.genus, "area": c.area, "volume": c.volume,
        })).collect::<Vec<_>>(),
        "findings": {
            "boundary_edges": findings_json(&r.boundary_edges, edge_json),
            "non_manifold_edges": findings_json(&r.non_manifold_edges, edge_json),
            "non_manifold_vertices": findings_json(&r.non_manifold_vertices, |v| json!(v)),
            "inconsistent_edges": findings_json(&r.inconsistent_edges, edge_json),
            "collapsed_triangles": findings_json(&r.collapsed_triangles, |v| json!(v)),
            "zero_area_triangles": findings_json(&r.zero_area_triangles, |v| json!(v)),
            "duplicate_triangles": findings_json(&r.duplicate_triangles, |v| json!(v)),
            "isolated_vertices": findings_json(&r.isolated_vertices, |v| json!(v)),
            "self_intersections": r.self_intersections.as_ref().map(|f| findings_json(f, |v| json!(v))),
        }
    })
}

fn yes(b: bool) -> &'static str {
    if b {
        "yes"
    } else {
        "NO"
    }
}

/// The report as text, one fact per line.
pub fn mesh_text(r: &MeshReport) -> String {
    let mut s = String::new();
    let mut line = |l: String| {
        s.push_str(&l);
        s.push('\n');
    };
    line(format!("mesh:        {} vertices, {} triangles, {} edges", r.vertices, r.triangles, r.edges));
    line(format!(
        "closed: {}   manifold: {}   oriented: {}",
        yes(r.is_closed()),
        yes(r.is_manifold()),
        yes(r.is_oriented())
    ));
    let genus = r.genus().map_or("-".to_string(), |g| g.to_string());
    line(format!("components:  {}   euler characteristic: {}   genus: {}", r.components.len(), r.euler, genus));
    line(format!("area:        {:.6}   enclosed volume: {:.6}", r.area, r.volume));
    line(format!(
        "quality:     smallest angle per triangle {:.1}° mean, {:.2}° minimum",
        r.min_angle_mean_deg, r.min_angle_deg
    ));
    if !r.bounds.is_empty() {
        let (a, b) = (r.bounds.min, r.bounds.max);
        line(format!(
            "bounds:      ({:.4}, {:.4}, {:.4}) to ({:.4}, {:.4}, {:.4})",
            a[0], a[1], a[2], b[0], b[1], b[2]
        ));
    }
    let edge_rows: [(&str, &Findings<EdgeFinding>); 3] = [
        ("boundary edges", &r.boundary_edges),
        ("non-manifold edges", &r.non_manifold_edges),
        ("inconsistently oriented edges", &r.inconsistent_edges),
    ];
    for (name, f) in edge_rows {
        if f.count > 0 {
            line(format!("{name}: {}", f.count));
            for e in &f.examples {
                line(format!("  {e}"));
            }
        }
    }
    let id_rows: [(&str, &Findings<u32>, &str); 4] = [
        ("non-manifold vertices", &r.non_manifold_vertices, "vertex"),
        ("collapsed triangles", &r.collapsed_triangles, "triangle"),
        ("zero-area triangles", &r.zero_area_triangles, "triangle"),
        ("isolated vertices", &r.isolated_vertices, "vertex"),
    ];
    for (name, f, what) in id_rows {
        if f.count > 0 {
            let ex: Vec<String> = f.examples.iter().map(|v| format!("{what} {v}")).collect();
            line(format!("{name}: {} (e.g. {})", f.count, ex.join(", ")));
        }
    }
    if r.duplicate_triangles.count > 0 {
        let ex: Vec<String> =
            r.duplicate_triangles.examples.iter().map(|p| format!("triangles {} and {}", p[0], p[1])).collect();
        line(format!("duplicate triangles: {} (e.g. {})", r.duplicate_triangles.count, ex.join(", ")));
    }
    if let Some(f) = &r.self_intersections {
        let ex: Vec<String> = f.examples.iter().map(|p| format!("triangles {} and {}", p[0], p[1])).collect();
        let ex = if ex.is_empty() { String::new() } else { format!(" (e.g. {})", ex.join(", ")) };
        line(format!("self-intersections: {} pairs of triangles{ex}", f.count));
    }
    s
}
