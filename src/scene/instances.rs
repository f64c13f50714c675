//! The scene as meshes and instances: each mesh's triangles in its own space, made once per
//! mesh asset (once per pose for skins and morph targets), and instances that place them with
//! a transform and a material. The GPU makes the world-space triangles from both
//! (shaders/scene/place.wgsl), so a moved entity costs one instance, not its triangles.

use std::collections::HashMap;
use std::sync::{Arc, OnceLock};

use bevy::math::Affine3A;
use bevy::prelude::*;
use bytemuck::{Pod, Zeroable};

use super::{GpuTriangle, GpuTriangleAttributes, LightKind, SceneData};

/// One mesh's triangles in its own space (a skinned mesh's: posed, in world space).
#[derive(Clone, Debug, Default)]
pub struct SceneMesh {
    /// Material 0: an instance gives it.
    pub triangles: Vec<GpuTriangle>,
    /// Per triangle, parallel to `triangles` (shared by the poses of one skin).
    pub attributes: Arc<Vec<GpuTriangleAttributes>>,
    /// Whether the mesh has vertex colours.
    pub colored: bool,
    /// `thinnest_slab`, found when first asked.
    pub slab: OnceLock<Option<Slab>>,
}

/// Two flat faces of a mesh that face opposite ways: their normal (of the first) and the
/// distance between their planes, in the mesh's space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slab {
    pub normal: Vec3,
    pub thickness: f32,
}

impl PartialEq for SceneMesh {
    /// The same triangles and attributes (what was found of them aside).
    fn eq(&self, other: &Self) -> bool {
        self.triangles == other.triangles
            && self.attributes == other.attributes
            && self.colored == other.colored
    }
}

impl SceneMesh {
    /// Its two flat-shaded faces facing opposite ways that lie closest together (a slab, a box,
    /// a window pane): made of clear glass, light may cross it straight through
    /// (`ScatterPaths::PANES`).
    pub fn thinnest_slab(&self) -> Option<Slab> {
        *self.slab.get_or_init(|| thinnest_slab(&self.triangles))
    }
}

impl SceneData {
    /// Whether clear glass of the scene is a pane (`ScatterPaths::PANES`): a sun's and the
    /// sky's light pass a slab whatever its thickness, a nearer light's only glass under 2 %
    /// of the scene's radius (PANE_SHARE in shaders/common/panes.wgsl).
    pub(super) fn has_panes(&self) -> bool {
        let sun = LightKind::Directional as u32;
        let parallel = self.sky[3] > 0.0 || self.lights.iter().any(|l| l.kind == sun);
        let thin = 0.02 * self.bounding_sphere().1;
        self.instances.iter().any(|i| {
            let material = self.materials.get(i.material as usize);
            let slab = self
                .meshes
                .get(i.mesh as usize)
                .and_then(|m| m.thinnest_slab());
            material.is_some_and(|m| m.is_pane())
                && slab.is_some_and(|s| parallel || i.slab_thickness(s) <= thin)
        })
    }
}

/// `SceneMesh::thinnest_slab` of these triangles: their face normals, where every corner's
/// normal is the face's, on a grid of 1/512 (an exact opposite lands on the opposite cell),
/// each with the offsets of its planes, sorted, so that each plane finds its nearest opposite
/// by bisection (a mesh of many parallel facets stays O(n log n)).
fn thinnest_slab(triangles: &[GpuTriangle]) -> Option<Slab> {
    let mut planes: HashMap<IVec3, (Vec3, Vec<f32>)> = HashMap::new();
    for t in triangles {
        let [a, b, c] = [t.position_a, t.position_b, t.position_c].map(Vec3::from);
        let Some(n) = (b - a).cross(c - a).try_normalize() else {
            continue;
        };
        let corners = [t.normal_a, t.normal_b, t.normal_c].map(Vec3::from);
        if !corners
            .iter()
            .all(|m| m.normalize_or_zero().dot(n) >= 0.9999)
        {
            continue;
        }
        let cell = (n * 512.0).round().as_ivec3();
        planes
            .entry(cell)
            .or_insert((n, Vec::new()))
            .1
            .push(n.dot(a));
    }
    for (_, offsets) in planes.values_mut() {
        offsets.sort_by(f32::total_cmp);
        offsets.dedup();
    }
    let mut thinnest: Option<Slab> = None;
    for (cell, (normal, offsets)) in &planes {
        let Some((_, opposite)) = planes.get(&-*cell) else {
            continue;
        };
        // Planes n·p = a and −n·p = b lie |a + b| apart: the b nearest −a, either side (and
        // past one at 0, the same plane faced both ways).
        for a in offsets {
            let at = opposite.partition_point(|&b| b < -a);
            for b in opposite[at.saturating_sub(1)..(at + 2).min(opposite.len())].iter() {
                let thickness = (a + b).abs();
                if thickness > 0.0 && thinnest.is_none_or(|s| thickness < s.thickness) {
                    thinnest = Some(Slab {
                        normal: *normal,
                        thickness,
                    });
                }
            }
        }
    }
    thinnest
}

/// One placed mesh (128 bytes), mirrored by `Instance` in shaders/scene/place.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuInstance {
    /// World from local, by rows: xyz the 3×3 part, w the translation.
    pub rows: [[f32; 4]; 3],
    /// The inverse transpose of the 3×3 part, by rows (w unused), for normals.
    pub normal_rows: [[f32; 4]; 3],
    /// The mesh's first triangle in the table of all meshes' triangles.
    pub first_local: u32,
    /// Its first triangle in the world-space table.
    pub first_world: u32,
    pub triangle_count: u32,
    /// Index into [`SceneData::materials`].
    pub material: u32,
    /// 1 when the transform mirrors (the winding is swapped to keep the front in front).
    pub mirrored: u32,
    /// Index into [`SceneData::meshes`].
    pub mesh: u32,
    pub _pad: [u32; 2],
}

impl GpuInstance {
    /// `None` when the transform is not finite or flattens the mesh (nothing could be hit).
    pub fn new(world_from_local: Affine3A, mesh: u32, material: u32) -> Option<Self> {
        let m = Mat3::from(world_from_local.matrix3);
        let det = m.determinant();
        if !world_from_local.is_finite() || !det.is_normal() {
            return None;
        }
        let n = m.inverse().transpose();
        let t = world_from_local.translation;
        let rows = |m: Mat3, w: Vec3| [0, 1, 2].map(|r| m.row(r).extend(w[r]).to_array());
        Some(Self {
            rows: rows(m, t.into()),
            normal_rows: rows(n, Vec3::ZERO),
            mesh,
            material,
            mirrored: u32::from(det < 0.0),
            ..default()
        })
    }

    fn point(&self, p: [f32; 3]) -> Vec3 {
        let p = Vec3::from(p).extend(1.0);
        Vec3::from(self.rows.map(|r| Vec4::from(r).dot(p)))
    }

    fn normal(&self, n: [f32; 3]) -> Vec3 {
        self.normal_transform(Vec3::from(n)).normalize_or_zero()
    }

    /// M⁻ᵀn, unnormalised: its length is how much the transform shrinks distances along n.
    fn normal_transform(&self, n: Vec3) -> Vec3 {
        Vec3::from(self.normal_rows.map(|r| Vec4::from(r).truncate().dot(n)))
    }

    /// How thick `slab` of its mesh is once placed (a transform keeps parallel faces
    /// parallel; the distance between them scales by 1/|M⁻ᵀn|).
    pub fn slab_thickness(&self, slab: Slab) -> f32 {
        slab.thickness
            / self
                .normal_transform(slab.normal)
                .length()
                .max(f32::MIN_POSITIVE)
    }

    /// A local triangle's three corner values (positions, normals, UVs, colours) in the order
    /// placement puts them: a mirroring transform swaps the second and third, to keep the
    /// front in front (as `place` in shaders/scene/place.wgsl does).
    pub fn placed_order<T>(&self, [a, b, c]: [T; 3]) -> [T; 3] {
        if self.mirrored != 0 {
            [a, c, b]
        } else {
            [a, b, c]
        }
    }

    /// A local triangle in world space, as the GPU places it.
    pub fn place(&self, t: &GpuTriangle) -> GpuTriangle {
        let p = [t.position_a, t.position_b, t.position_c].map(|p| self.point(p).to_array());
        let n = [t.normal_a, t.normal_b, t.normal_c].map(|n| self.normal(n).to_array());
        let [position_a, position_b, position_c] = self.placed_order(p);
        let [normal_a, normal_b, normal_c] = self.placed_order(n);
        GpuTriangle {
            position_a,
            position_b,
            position_c,
            normal_a,
            normal_b,
            normal_c,
            material: self.material,
            ..default()
        }
    }

    /// Axis-aligned bounds of `mesh` placed by this instance.
    pub fn bounds(&self, mesh: &SceneMesh) -> Option<(Vec3, Vec3)> {
        let mut points = mesh
            .triangles
            .iter()
            .flat_map(|t| [t.position_a, t.position_b, t.position_c])
            .map(|p| self.point(p));
        let first = points.next()?;
        Some(points.fold((first, first), |(lo, hi), p| (lo.min(p), hi.max(p))))
    }
}

impl SceneData {
    /// How many world-space triangles the scene has.
    pub fn triangle_count(&self) -> usize {
        self.instances
            .last()
            .map_or(0, |i| (i.first_world + i.triangle_count) as usize)
    }

    /// World-space triangle `index`, as the GPU places it.
    pub fn triangle(&self, index: usize) -> Option<GpuTriangle> {
        let at = self
            .instances
            .partition_point(|i| (i.first_world + i.triangle_count) as usize <= index);
        let instance = self.instances.get(at)?;
        let mesh = self.meshes.get(instance.mesh as usize)?;
        let local = mesh.triangles.get(index - instance.first_world as usize)?;
        Some(instance.place(local))
    }

    /// Every world-space triangle (made on the CPU: for tests and benches).
    pub fn world_triangles(&self) -> Vec<GpuTriangle> {
        self.instances
            .iter()
            .flat_map(|i| {
                self.meshes[i.mesh as usize]
                    .triangles
                    .iter()
                    .map(move |t| i.place(t))
            })
            .collect()
    }

    /// Per world-space triangle UVs and colours (empty when untextured), their corners in the
    /// placed triangles' order (a mirrored instance swaps the second and third).
    pub fn world_attributes(&self) -> Vec<GpuTriangleAttributes> {
        if !self.is_textured() {
            return Vec::new();
        }
        self.instances
            .iter()
            .flat_map(|i| {
                (self.meshes[i.mesh as usize].attributes.iter()).map(|a| GpuTriangleAttributes {
                    uv: i.placed_order(a.uv),
                    color: i.placed_order(a.color),
                })
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slabs_have_parallel_faces_and_spheres_and_single_quads_do_not() {
        let flat = |a: [f32; 3], b: [f32; 3], c: [f32; 3]| {
            let n = (Vec3::from(b) - Vec3::from(a)).cross(Vec3::from(c) - Vec3::from(a));
            let n = n.normalize().to_array();
            GpuTriangle {
                position_a: a,
                position_b: b,
                position_c: c,
                normal_a: n,
                normal_b: n,
                normal_c: n,
                ..default()
            }
        };
        // A slab 0.25 thick: its top faces +y at 0.25, its bottom −y at 0.
        let top = flat([0.0, 0.25, 0.0], [0.0, 0.25, 1.0], [1.0, 0.25, 0.0]);
        let bottom = flat([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]);
        let side = flat([0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]);
        let slab = thinnest_slab(&[top, side, bottom]).unwrap();
        assert!((slab.thickness - 0.25).abs() < 1e-6, "{slab:?}");
        assert!(thinnest_slab(&[top, side]).is_none());
        // Opposite faces with smooth normals (a sphere's) are curved, not parallel.
        let mut round = bottom;
        round.normal_a = Vec3::new(0.3, -1.0, 0.0).normalize().to_array();
        assert!(thinnest_slab(&[top, round]).is_none());
        // Placed scaled by 4 along y, the slab is 1 thick.
        let placed = Affine3A::from_scale(Vec3::new(1.0, 4.0, 1.0));
        let instance = GpuInstance::new(placed, 0, 0).unwrap();
        assert!((instance.slab_thickness(slab) - 1.0).abs() < 1e-5);
    }

    #[test]
    fn mirrored_instances_keep_the_front_and_normals_follow_the_inverse_transpose() {
        let local = GpuTriangle {
            position_a: [0.0, 0.0, 0.0],
            position_b: [1.0, 0.0, 0.0],
            position_c: [0.0, 1.0, 0.0],
            normal_a: [0.0, 0.0, 1.0],
            normal_b: [1.0, 0.0, 1.0],
            normal_c: [0.0, 0.0, 1.0],
            ..default()
        };
        let front = |t: &GpuTriangle| {
            let [a, b, c] = t.positions();
            (b - a).cross(c - a).normalize()
        };
        // Mirrored in x and stretched in y: the geometric normal still agrees with the shading one.
        let m = Affine3A::from_scale(Vec3::new(-1.0, 3.0, 1.0));
        let i = GpuInstance::new(m, 0, 7).unwrap();
        let t = i.place(&local);
        assert_eq!(t.material, 7);
        assert!(front(&t).dot(Vec3::from(t.normal_a)) > 0.99);
        let slanted = Vec3::from(t.normal_c);
        let expected = Vec3::new(-1.0, 0.0, 1.0).normalize();
        assert!(slanted.distance(expected) < 1e-6, "{slanted}");
        assert!(GpuInstance::new(Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0)), 0, 0).is_none());
        let nan = Affine3A::from_translation(Vec3::splat(f32::NAN));
        assert!(GpuInstance::new(nan, 0, 0).is_none());
    }

    /// A mirrored instance's texture coordinates and colours follow its swapped corners, so
    /// each placed corner keeps its own (a mirrored textured asset showed its texture sheared).
    #[test]
    fn mirrored_instances_keep_each_corners_attributes() {
        let local = GpuTriangle {
            position_a: [0.0, 0.0, 0.0],
            position_b: [1.0, 0.0, 0.0],
            position_c: [0.0, 1.0, 0.0],
            ..default()
        };
        let uv = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
        let mesh = SceneMesh {
            triangles: vec![local],
            attributes: Arc::new(vec![GpuTriangleAttributes {
                uv,
                color: [[1, 1], [2, 2], [3, 3]],
            }]),
            colored: true,
            ..default()
        };
        let material = super::super::GpuMaterial {
            flags: super::super::MaterialFlags::TEXTURED.bits(),
            ..default()
        };
        let plain = GpuInstance::new(Affine3A::IDENTITY, 0, 0).unwrap();
        let mirror = GpuInstance::new(Affine3A::from_scale(Vec3::new(-1.0, 1.0, 1.0)), 0, 0);
        let data = SceneData {
            meshes: vec![Arc::new(mesh)],
            instances: vec![plain, mirror.unwrap()],
            materials: vec![material],
            ..default()
        };
        let world = data.world_attributes();
        assert_eq!(world[0].uv, uv);
        for (instance, attributes) in data.instances.iter().zip(&world) {
            let placed = instance.place(&local).positions();
            for (corner, uv) in placed.iter().zip(attributes.uv) {
                // Local (u, v) sits at (±u, v) in this test's mesh.
                assert_eq!(corner.x.abs(), uv[0], "{instance:?}");
                assert_eq!(corner.y, uv[1]);
            }
        }
        assert_eq!(world[1].color, [[1, 1], [3, 3], [2, 2]]);
    }
}
