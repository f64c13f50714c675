//! A Bevy `Mesh` to triangles: in its own space once per asset, or posed by its skin and
//! morph targets once per pose ([`MeshCache`]).

use std::borrow::Cow;
use std::sync::Arc;

use bevy::ecs::entity::EntityHashSet;
use bevy::math::Affine3A;
use bevy::mesh::{Indices, PrimitiveTopology, VertexAttributeValues};
use bevy::platform::collections::HashMap;
use bevy::prelude::*;

use super::{GpuInstance, GpuTriangle, GpuTriangleAttributes, SceneMesh};

/// What posed a skinned or morphed mesh: its asset, whether it holds the second UV set, then
/// the weights and joint matrices.
type PoseKey = (AssetId<Mesh>, bool, Vec<f32>);

/// World bounds, with the mesh and placement they were made for.
type PlacedBounds = (Arc<SceneMesh>, GpuInstance, (Vec3, Vec3));

/// Meshes made into [`SceneMesh`]es, kept across extractions: a moved entity reuses its mesh,
/// a new pose remakes only that entity's.
#[derive(Resource, Default)]
pub(super) struct MeshCache {
    /// Meshes placed by their entity's transform alone, by asset and whether they hold the
    /// second UV set.
    rigid: HashMap<(AssetId<Mesh>, bool), Result<Arc<SceneMesh>, String>>,
    /// Skinned or morphed meshes, by entity, with what posed them.
    posed: HashMap<Entity, (PoseKey, Arc<SceneMesh>)>,
    /// World bounds by entity.
    bounds: HashMap<Entity, PlacedBounds>,
}

impl MeshCache {
    /// Drops what was made from `id` (it changed).
    pub(super) fn forget(&mut self, id: AssetId<Mesh>) {
        self.rigid.retain(|(mesh, _), _| *mesh != id);
        self.posed.retain(|_, ((mesh, ..), _)| *mesh != id);
    }

    /// Drops the entities not in `seen` (gone or hidden).
    pub(super) fn keep(&mut self, seen: &EntityHashSet) {
        self.posed.retain(|e, _| seen.contains(e));
        self.bounds.retain(|e, _| seen.contains(e));
    }

    /// `entity`'s mesh as triangles with texture coordinates from its second UV set
    /// (`second_uvs`) or its first: shared by every entity of the asset, or posed by `joints`
    /// (world space) and morph `weights` (remade only when they change).
    pub(super) fn mesh(
        &mut self,
        entity: Entity,
        handle: &Handle<Mesh>,
        mesh: &Mesh,
        joints: Option<&[Affine3A]>,
        weights: &[f32],
        second_uvs: bool,
    ) -> Result<Arc<SceneMesh>, String> {
        let id = handle.id();
        if joints.is_none() && weights.iter().all(|&w| w == 0.0) {
            self.posed.remove(&entity);
            return (self.rigid.entry((id, second_uvs)))
                .or_insert_with(|| {
                    make(mesh, &Pose::Rigid(Affine3A::IDENTITY), &[], second_uvs).map(Arc::new)
                })
                .clone();
        }
        let mut key = weights.to_vec();
        for j in joints.unwrap_or_default() {
            key.extend_from_slice(&j.to_cols_array());
        }
        let key = (id, second_uvs, key);
        if let Some((seen, made)) = self.posed.get(&entity)
            && *seen == key
        {
            return Ok(made.clone());
        }
        let pose = joints.map_or(Pose::Rigid(Affine3A::IDENTITY), Pose::Skinned);
        let mut made = make(mesh, &pose, weights, second_uvs)?;
        // A new pose keeps the attributes of the last.
        if let Some((_, last)) = self.posed.get(&entity)
            && last.attributes == made.attributes
        {
            made.attributes = last.attributes.clone();
        }
        let made = Arc::new(made);
        self.posed.insert(entity, (key, made.clone()));
        Ok(made)
    }

    /// The world bounds of `mesh` placed by `instance`, remade only when either changed.
    pub(super) fn bounds(
        &mut self,
        entity: Entity,
        instance: &GpuInstance,
        mesh: &Arc<SceneMesh>,
    ) -> Option<(Vec3, Vec3)> {
        if let Some((seen, placed, bounds)) = self.bounds.get(&entity)
            && Arc::ptr_eq(seen, mesh)
            && placed.rows == instance.rows
        {
            return Some(*bounds);
        }
        let bounds = instance.bounds(mesh)?;
        self.bounds
            .insert(entity, (mesh.clone(), *instance, bounds));
        Some(bounds)
    }
}

/// A mesh's triangles posed by `pose` after its morph targets at `weights`.
fn make(mesh: &Mesh, pose: &Pose, weights: &[f32], second_uvs: bool) -> Result<SceneMesh, String> {
    let (mut triangles, mut attributes) = (Vec::new(), Vec::new());
    let colored = append_triangles(
        mesh,
        pose,
        weights,
        0,
        second_uvs,
        &mut triangles,
        &mut attributes,
    )?;
    Ok(SceneMesh {
        triangles,
        attributes: Arc::new(attributes),
        colored,
        ..default()
    })
}

/// Where a mesh's vertices go in world space.
pub(super) enum Pose<'a> {
    /// One transform: the entity's.
    Rigid(Affine3A),
    /// Skinning: each vertex blends the world-from-bind-space matrices (a joint's world
    /// transform times its inverse bind pose) of its joints, by weight; the entity's own
    /// transform is ignored, as Bevy's renderer does.
    Skinned(&'a [Affine3A]),
}

/// Appends the mesh's triangles, posed ([`Pose`], after the morph targets at `morph_weights`)
/// in world space, with the given material, and their texture coordinates (`UV_0` or `UV_1`) and
/// vertex colours (`COLOR`) to `attributes`. Accepts u16, u32 or no indices, with or without
/// normals (flat normals then), UVs (zero then) and colours (white then); degenerate
/// triangles are dropped. Returns whether the mesh has vertex colours, or why it cannot be
/// used at all.
pub(super) fn append_triangles(
    mesh: &Mesh,
    pose: &Pose,
    morph_weights: &[f32],
    material: u32,
    second_uvs: bool,
    out: &mut Vec<GpuTriangle>,
    attributes: &mut Vec<GpuTriangleAttributes>,
) -> Result<bool, String> {
    let topology = mesh.primitive_topology();
    if !matches!(
        topology,
        PrimitiveTopology::TriangleList | PrimitiveTopology::TriangleStrip
    ) {
        return Err(format!("topology {topology:?} has no triangles"));
    }
    let positions = match mesh.try_attribute(Mesh::ATTRIBUTE_POSITION) {
        Ok(VertexAttributeValues::Float32x3(p)) => p,
        Ok(_) => return Err("positions are not Float32x3".into()),
        Err(e) => {
            return Err(format!(
                "positions unavailable ({e}); keep MAIN_WORLD asset usage"
            ));
        }
    };
    let normals = match mesh.try_attribute_option(Mesh::ATTRIBUTE_NORMAL) {
        Ok(Some(VertexAttributeValues::Float32x3(n))) if n.len() == positions.len() => {
            Some(n.as_slice())
        }
        _ => None,
    };
    let uv_set = match second_uvs {
        false => Mesh::ATTRIBUTE_UV_0,
        true => Mesh::ATTRIBUTE_UV_1,
    };
    let uvs = match mesh.try_attribute_option(uv_set) {
        Ok(Some(VertexAttributeValues::Float32x2(uv))) if uv.len() == positions.len() => Some(uv),
        _ => None,
    };
    let colors = mesh
        .try_attribute_option(Mesh::ATTRIBUTE_COLOR)
        .ok()
        .flatten()
        .and_then(vertex_colors)
        .filter(|c| c.len() == positions.len());
    let indices: Box<dyn Iterator<Item = usize>> = match mesh.try_indices_option() {
        Ok(Some(Indices::U16(i))) => Box::new(i.iter().map(|&i| i as usize)),
        Ok(Some(Indices::U32(i))) => Box::new(i.iter().map(|&i| i as usize)),
        _ => Box::new(0..positions.len()),
    };
    let mut indices: Vec<usize> = indices.collect();
    if topology == PrimitiveTopology::TriangleStrip {
        indices = strip_to_list(&indices);
    }
    if let Some(bad) = indices.iter().find(|&&i| i >= positions.len()) {
        return Err(format!(
            "index {bad} is out of range ({} vertices)",
            positions.len()
        ));
    }
    let (positions, normals) = morphed(mesh, positions, normals, morph_weights)?;
    let placed = place(mesh, pose, &positions, normals.as_deref())?;
    for tri in indices.chunks_exact(3) {
        let mut ids = [tri[0], tri[1], tri[2]];
        // A mirroring transform flips the winding; swap two vertices so the front stays in
        // front.
        if placed.mirrored(ids[0]) {
            ids.swap(1, 2);
        }
        let p = ids.map(|i| placed.positions[i]);
        let face = (p[1] - p[0]).cross(p[2] - p[0]);
        let Some(flat) = face.try_normalize() else {
            continue; // degenerate: no area, nothing can hit it
        };
        if !p.iter().all(|v| v.is_finite()) {
            continue;
        }
        let n = ids.map(|i| placed.normals.get(i).copied().flatten().unwrap_or(flat));
        out.push(GpuTriangle {
            position_a: p[0].into(),
            material,
            position_b: p[1].into(),
            position_c: p[2].into(),
            normal_a: n[0].into(),
            normal_b: n[1].into(),
            normal_c: n[2].into(),
            ..default()
        });
        attributes.push(GpuTriangleAttributes {
            uv: ids.map(|i| {
                uvs.map_or([0.0; 2], |uv| {
                    let [u, v] = uv[i];
                    if u.is_finite() && v.is_finite() {
                        [u, v]
                    } else {
                        [0.0; 2]
                    }
                })
            }),
            color: ids.map(|i| colors.as_ref().map_or([u32::MAX; 2], |c| c[i])),
        });
    }
    Ok(colors.is_some())
}

/// Vertex colours as 16-bit unorm pairs (rg, ba), linear, from the formats Bevy's loaders make.
fn vertex_colors(values: &VertexAttributeValues) -> Option<Vec<[u32; 2]>> {
    let unorm = |v: f32| (v.clamp(0.0, 1.0) * 65535.0).round() as u32;
    let pack = |c: [f32; 4]| {
        [
            unorm(c[0]) | unorm(c[1]) << 16,
            unorm(c[2]) | unorm(c[3]) << 16,
        ]
    };
    match values {
        VertexAttributeValues::Float32x4(c) => Some(c.iter().map(|&c| pack(c)).collect()),
        VertexAttributeValues::Float32x3(c) => {
            Some(c.iter().map(|&[r, g, b]| pack([r, g, b, 1.0])).collect())
        }
        _ => None,
    }
}

/// Vertex positions or normals, borrowed from the mesh or morphed.
type Vectors<'a> = Cow<'a, [[f32; 3]]>;

/// Positions and normals after the morph targets at `weights` (none: the mesh's own).
fn morphed<'a>(
    mesh: &Mesh,
    positions: &'a [[f32; 3]],
    normals: Option<&'a [[f32; 3]]>,
    weights: &[f32],
) -> Result<(Vectors<'a>, Option<Vectors<'a>>), String> {
    let targets = match mesh.try_morph_targets() {
        Ok(t) if weights.iter().any(|&w| w != 0.0) && !positions.is_empty() => t,
        _ => return Ok((Cow::Borrowed(positions), normals.map(Cow::Borrowed))),
    };
    let count = targets.len() / positions.len();
    if count * positions.len() != targets.len() {
        return Err(format!(
            "{} morph displacements do not divide into {} vertices",
            targets.len(),
            positions.len()
        ));
    }
    let mut p: Vec<Vec3> = positions.iter().map(|&v| Vec3::from(v)).collect();
    let mut n: Option<Vec<Vec3>> = normals.map(|n| n.iter().map(|&v| Vec3::from(v)).collect());
    for (target, &w) in targets.chunks_exact(positions.len()).zip(weights) {
        if w == 0.0 || !w.is_finite() {
            continue;
        }
        for (i, d) in target.iter().enumerate() {
            p[i] += w * d.position;
            if let Some(n) = &mut n {
                n[i] += w * d.normal;
            }
        }
    }
    let back = |v: Vec<Vec3>| Cow::Owned(v.iter().map(Vec3::to_array).collect());
    Ok((back(p), n.map(back)))
}

/// A mesh's vertices in world space.
struct Placed {
    positions: Vec<Vec3>,
    /// Unit normals (none where the mesh has none or they collapse).
    normals: Vec<Option<Vec3>>,
    /// Vertices whose transform mirrors (empty: none does).
    mirrored: Vec<bool>,
}

impl Placed {
    fn mirrored(&self, vertex: usize) -> bool {
        self.mirrored.get(vertex).copied().unwrap_or(false)
    }
}

/// Each vertex through its transform: the entity's, or its joints' blend.
fn place(
    mesh: &Mesh,
    pose: &Pose,
    positions: &[[f32; 3]],
    normals: Option<&[[f32; 3]]>,
) -> Result<Placed, String> {
    let through = |m: &Affine3A, normal_matrix: &Mat3, i: usize| {
        let p = m.transform_point3(Vec3::from(positions[i]));
        let n = normals.and_then(|n| (*normal_matrix * Vec3::from(n[i])).try_normalize());
        (p, n)
    };
    match pose {
        Pose::Rigid(m) => {
            let normal_matrix = Mat3::from(m.matrix3).inverse().transpose();
            let (positions, normals): (Vec<_>, Vec<_>) = (0..positions.len())
                .map(|i| through(m, &normal_matrix, i))
                .unzip();
            let mirrored = if m.matrix3.determinant() < 0.0 {
                vec![true; positions.len()]
            } else {
                Vec::new()
            };
            Ok(Placed {
                positions,
                normals,
                mirrored,
            })
        }
        Pose::Skinned(joints) => {
            let influences = skin_influences(mesh, positions.len())?;
            let mut placed = Placed {
                positions: Vec::with_capacity(positions.len()),
                normals: Vec::with_capacity(positions.len()),
                mirrored: Vec::with_capacity(positions.len()),
            };
            for (i, (index, weight)) in influences.enumerate() {
                let m = blend(joints, index, weight)?;
                let normal_matrix = Mat3::from(m.matrix3).inverse().transpose();
                let (p, n) = through(&m, &normal_matrix, i);
                placed.positions.push(p);
                placed.normals.push(n);
                placed.mirrored.push(m.matrix3.determinant() < 0.0);
            }
            Ok(placed)
        }
    }
}

/// Each vertex's four joint indices and weights.
fn skin_influences(
    mesh: &Mesh,
    vertices: usize,
) -> Result<impl Iterator<Item = ([u16; 4], [f32; 4])> + '_, String> {
    let index = match mesh.try_attribute_option(Mesh::ATTRIBUTE_JOINT_INDEX) {
        Ok(Some(VertexAttributeValues::Uint16x4(j))) if j.len() == vertices => j,
        _ => return Err("a skinned mesh without Uint16x4 joint indices per vertex".into()),
    };
    let weight = match mesh.try_attribute_option(Mesh::ATTRIBUTE_JOINT_WEIGHT) {
        Ok(Some(VertexAttributeValues::Float32x4(w))) if w.len() == vertices => w,
        _ => return Err("a skinned mesh without Float32x4 joint weights per vertex".into()),
    };
    Ok(index.iter().copied().zip(weight.iter().copied()))
}

/// The weighted sum of a vertex's joint matrices, weights normalised (all zero: bind space).
fn blend(joints: &[Affine3A], index: [u16; 4], weight: [f32; 4]) -> Result<Affine3A, String> {
    let weight = weight.map(|w| if w.is_finite() { w.max(0.0) } else { 0.0 });
    let total: f32 = weight.iter().sum();
    if total <= 0.0 {
        return Ok(Affine3A::IDENTITY);
    }
    let mut matrix3 = Mat3::ZERO;
    let mut translation = Vec3::ZERO;
    for (&j, &w) in index.iter().zip(&weight) {
        if w == 0.0 {
            continue;
        }
        let Some(joint) = joints.get(j as usize) else {
            return Err(format!(
                "joint index {j} is out of range ({} joints)",
                joints.len()
            ));
        };
        matrix3 += Mat3::from(joint.matrix3) * (w / total);
        translation += Vec3::from(joint.translation) * (w / total);
    }
    Ok(Affine3A::from_mat3_translation(matrix3, translation))
}

/// A triangle strip's corners as a list (glTF's `TRIANGLE_STRIP`): every other triangle's
/// first two corners swapped so that all keep the strip's front.
fn strip_to_list(strip: &[usize]) -> Vec<usize> {
    (0..strip.len().saturating_sub(2))
        .flat_map(|k| {
            let (a, b) = if k % 2 == 0 { (k, k + 1) } else { (k + 1, k) };
            [strip[a], strip[b], strip[k + 2]]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A strip of four corners is two triangles facing one way; a strip too short is none.
    #[test]
    fn strips_become_lists_that_keep_their_front() {
        let corners = [
            Vec3::ZERO,
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
        ];
        let list = strip_to_list(&[0, 1, 2, 3]);
        assert_eq!(list, vec![0, 1, 2, 2, 1, 3]);
        for t in list.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| corners[i]);
            assert_eq!((b - a).cross(c - a).normalize(), Vec3::NEG_Z);
        }
        assert!(strip_to_list(&[0, 1]).is_empty());
        assert!(strip_to_list(&[]).is_empty());
    }
}
