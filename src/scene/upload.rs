//! What a scene change sends to the GPU: only the tables, meshes and instances that changed,
//! counted in bytes (the stats' `scene_upload_bytes`).

use std::sync::Arc;

use bevy::render::render_resource::{Buffer, TextureFormat, TextureView};
use bevy::render::renderer::{RenderDevice, RenderQueue};
use bytemuck::Pod;

use super::prepare::{SceneBuffers, constant_texture, storage_buffer};
use super::{GpuMaterial, GpuTriangleAttributes, PackedTriangle, SceneData, same};

/// Materials a row of the materials' texture holds, and the 16-byte texels each takes
/// (`MATERIALS_ROW`, `MATERIAL_TEXELS` in shaders/scene/scene.wgsl).
pub const MATERIALS_ROW: usize = 64;
pub const MATERIAL_TEXELS: usize = std::mem::size_of::<GpuMaterial>() / 16;
const _: () = assert!(std::mem::size_of::<GpuMaterial>() == 160);

/// `materials` as the unsigned texture the shaders read (`scene_material`), zero-padded to
/// whole rows (one row of zeros for none).
pub(crate) fn material_texture(
    device: &RenderDevice,
    queue: &RenderQueue,
    materials: &[GpuMaterial],
) -> TextureView {
    let rows = material_rows(materials.len());
    let mut bytes = vec![0u8; material_bytes(materials.len()) as usize];
    let items: &[u8] = bytemuck::cast_slice(materials);
    bytes[..items.len()].copy_from_slice(items);
    let width = (MATERIALS_ROW * MATERIAL_TEXELS) as u32;
    constant_texture(
        device,
        queue,
        "rppm_materials",
        [width, rows],
        TextureFormat::Rgba32Uint,
        &bytes,
    )
}

/// Bytes of the materials' texture for `count` materials (whole rows).
pub fn material_bytes(count: usize) -> u64 {
    (material_rows(count) as usize * MATERIALS_ROW * std::mem::size_of::<GpuMaterial>()) as u64
}

/// Rows of the materials' texture for `count` materials.
pub fn material_rows(count: usize) -> u32 {
    count.div_ceil(MATERIALS_ROW).max(1) as u32
}

/// Uploads of one scene change, and their bytes.
pub(super) struct Upload<'a> {
    pub device: &'a RenderDevice,
    pub queue: &'a RenderQueue,
    pub bytes: u64,
}

impl Upload<'_> {
    /// A new buffer holding `items` (one zeroed item when there are none).
    pub fn new_buffer<T: Pod + Default>(&mut self, label: &'static str, items: &[T]) -> Buffer {
        let buffer = storage_buffer(self.device, label, items);
        self.bytes += buffer.size();
        buffer
    }

    /// The scene table `items` picks, with the last buffer `buffer` picks when it holds the
    /// same items.
    pub fn table<T: Pod + Default>(
        &mut self,
        last: Option<&SceneBuffers>,
        data: &SceneData,
        items: fn(&SceneData) -> &[T],
        buffer: fn(&SceneBuffers) -> &Buffer,
        label: &'static str,
    ) -> Buffer {
        match last {
            Some(l) if same(items(&l.data), items(data)) => buffer(l).clone(),
            _ => self.new_buffer(label, items(data)),
        }
    }

    /// The last buffer with the items that changed written into it (runs of them) when the
    /// count is the same, else a new one; and whether anything was written.
    pub fn diff<T: Pod + Default>(
        &mut self,
        last: Option<(&Buffer, &[T])>,
        items: &[T],
        label: &'static str,
    ) -> (Buffer, bool) {
        let Some((buffer, old)) =
            last.filter(|(_, old)| old.len() == items.len() && !old.is_empty())
        else {
            return (self.new_buffer(label, items), true);
        };
        let size = std::mem::size_of::<T>();
        let differs = |i: usize| !same(&old[i..=i], &items[i..=i]);
        let (mut i, mut changed) = (0, false);
        while i < items.len() {
            if !differs(i) {
                i += 1;
                continue;
            }
            let start = i;
            while i < items.len() && differs(i) {
                i += 1;
            }
            let run = bytemuck::cast_slice(&items[start..i]);
            self.queue.write_buffer(buffer, (start * size) as u64, run);
            self.bytes += run.len() as u64;
            changed = true;
        }
        (buffer.clone(), changed)
    }

    /// The meshes' triangles: when every mesh keeps its size and place, only the meshes that
    /// changed (a new pose) are written; else all anew. Whether anything was written.
    pub fn meshes(&mut self, last: Option<&SceneBuffers>, data: &SceneData) -> (Buffer, bool) {
        let pack = |m: &super::SceneMesh| -> Vec<PackedTriangle> {
            m.triangles.iter().map(PackedTriangle::from).collect()
        };
        if let Some(l) = last
            && !data.meshes.is_empty()
            && l.data.meshes.len() == data.meshes.len()
            && (l.data.meshes.iter().zip(&data.meshes))
                .all(|(a, b)| a.triangles.len() == b.triangles.len())
        {
            let (mut offset, mut changed) = (0u64, false);
            for (old, new) in l.data.meshes.iter().zip(&data.meshes) {
                let bytes = (new.triangles.len() * std::mem::size_of::<PackedTriangle>()) as u64;
                if !Arc::ptr_eq(old, new) && old.triangles != new.triangles {
                    let packed = pack(new);
                    self.queue
                        .write_buffer(&l.meshes, offset, bytemuck::cast_slice(&packed));
                    self.bytes += bytes;
                    changed = true;
                }
                offset += bytes;
            }
            return (l.meshes.clone(), changed);
        }
        let packed: Vec<PackedTriangle> = data.meshes.iter().flat_map(|m| pack(m)).collect();
        (self.new_buffer("rppm_meshes", &packed), true)
    }

    /// The materials as an unsigned texture, `MATERIALS_ROW` a row (llvmpipe fetches a texel
    /// for 8 lanes at once, where it reads a storage buffer lane by lane); the last one when
    /// they did not change.
    pub fn materials(&mut self, last: Option<&SceneBuffers>, data: &SceneData) -> TextureView {
        if let Some(l) = last
            && same(&l.data.materials, &data.materials)
        {
            return l.materials.clone();
        }
        self.bytes += material_bytes(data.materials.len());
        material_texture(self.device, self.queue, &data.materials)
    }

    /// Per world-space triangle UVs and colours: kept while the instances show the same
    /// meshes' attributes in the same order (a moved or re-posed mesh keeps them).
    pub fn attributes(&mut self, last: Option<&SceneBuffers>, data: &SceneData) -> Buffer {
        let textured = data.is_textured();
        let kept = last.filter(|l| {
            let attributes = |d: &SceneData, i: &super::GpuInstance| {
                d.meshes[i.mesh as usize].attributes.clone()
            };
            l.data.is_textured() == textured
                && (!textured
                    || l.data.instances.len() == data.instances.len()
                        && (l.data.instances.iter().zip(&data.instances)).all(|(a, b)| {
                            a.mirrored == b.mirrored
                                && Arc::ptr_eq(&attributes(&l.data, a), &attributes(data, b))
                        }))
        });
        match kept {
            Some(l) => l.attributes.clone(),
            None if textured => {
                self.new_buffer("rppm_triangle_attributes", &data.world_attributes())
            }
            None => self.new_buffer::<GpuTriangleAttributes>("rppm_triangle_attributes", &[]),
        }
    }
}
