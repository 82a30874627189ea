//! Data written beside a mesh's positions and normals: per-vertex named scalar attributes
//! (sampled volumes, `--attribute`) and colours (`--color-by`), per-triangle labels (`--labels`).

use isoforge::mesh::Mesh;

/// Extra mesh data; vertex arrays have one entry per vertex, `triangle_labels` one per triangle.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MeshData {
    /// Named scalars, written as PLY `float NAME`, glTF `_NAME` attributes.
    pub scalars: Vec<(String, Vec<f32>)>,
    /// sRGB colours, written as PLY `red green blue`, glTF `COLOR_0`, OBJ `v x y z r g b`.
    pub colors: Option<Vec<[u8; 3]>>,
    /// The label each triangle bounds (PLY face property `label`).
    pub triangle_labels: Option<Vec<i32>>,
}

impl MeshData {
    /// True when there is nothing to write.
    pub fn is_empty(&self) -> bool {
        self.scalars.is_empty() && self.colors.is_none() && self.triangle_labels.is_none()
    }

    /// Checks that every array has one entry per vertex of `mesh`.
    pub fn fits(&self, mesh: &Mesh) -> bool {
        let n = mesh.positions.len();
        self.scalars.iter().all(|(_, v)| v.len() == n)
            && self.colors.as_ref().is_none_or(|c| c.len() == n)
            && self.triangle_labels.as_ref().is_none_or(|l| l.len() == mesh.triangles.len())
    }
}

/// A mesh with a name and its vertex data, one of several written to one glTF file.
#[derive(Debug, Clone, Copy)]
pub struct NamedMesh<'a> {
    /// Name of the glTF mesh and node (e.g. `iso 300`).
    pub name: &'a str,
    /// The mesh.
    pub mesh: &'a Mesh,
    /// Its per-vertex data.
    pub data: &'a MeshData,
}
