//! A Bevy `Mesh` to world-space triangles.

use bevy::math::Affine3A;
use bevy::mesh::{Indices, PrimitiveTopology, VertexAttributeValues};
use bevy::prelude::*;

use super::{GpuTriangle, GpuTriangleAttributes};

/// Appends the mesh's triangles, transformed to world space, with the given material, and
/// their texture coordinates (`UV_0`) and vertex colours (`COLOR`) to `attributes`.
/// Accepts u16, u32 or no indices, with or without normals (flat normals then), UVs (zero
/// then) and colours (white then); degenerate triangles are dropped. Returns whether the mesh
/// has vertex colours, or why it cannot be used at all.
pub(super) fn append_triangles(
    mesh: &Mesh,
    world_from_local: &Affine3A,
    material: u32,
    out: &mut Vec<GpuTriangle>,
    attributes: &mut Vec<GpuTriangleAttributes>,
) -> Result<bool, String> {
    if mesh.primitive_topology() != PrimitiveTopology::TriangleList {
        return Err(format!(
            "topology {:?} is not a triangle list",
            mesh.primitive_topology()
        ));
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
        Ok(Some(VertexAttributeValues::Float32x3(n))) if n.len() == positions.len() => Some(n),
        _ => None,
    };
    let uvs = match mesh.try_attribute_option(Mesh::ATTRIBUTE_UV_0) {
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
    let indices: Vec<usize> = indices.collect();
    if let Some(bad) = indices.iter().find(|&&i| i >= positions.len()) {
        return Err(format!(
            "index {bad} is out of range ({} vertices)",
            positions.len()
        ));
    }
    let normal_matrix = Mat3::from(world_from_local.matrix3).inverse().transpose();
    // A mirroring transform flips the winding; swap two vertices so the front stays in front.
    let mirrored = world_from_local.matrix3.determinant() < 0.0;
    for tri in indices.chunks_exact(3) {
        let mut ids = [tri[0], tri[1], tri[2]];
        if mirrored {
            ids.swap(1, 2);
        }
        let p = ids.map(|i| world_from_local.transform_point3(Vec3::from(positions[i])));
        let face = (p[1] - p[0]).cross(p[2] - p[0]);
        let Some(flat) = face.try_normalize() else {
            continue; // degenerate: no area, nothing can hit it
        };
        if !p.iter().all(|v| v.is_finite()) {
            continue;
        }
        let n = ids.map(|i| {
            normals
                .and_then(|n| (normal_matrix * Vec3::from(n[i])).try_normalize())
                .unwrap_or(flat)
        });
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
