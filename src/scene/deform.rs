//! Skinned meshes and morph targets: what poses a mesh beyond its entity's transform, and
//! whether that changed since the last extraction.

use bevy::ecs::system::SystemParam;
use bevy::math::Affine3A;
use bevy::mesh::morph::{MeshMorphWeights, MorphWeights};
use bevy::mesh::skinning::{SkinnedMesh, SkinnedMeshInverseBindposes};
use bevy::platform::collections::HashMap;
use bevy::prelude::*;

/// A mesh entity's skin.
pub(super) enum Skin {
    /// Not skinned: its entity's transform places it.
    None,
    /// Its inverse bind poses are still loading.
    Loading,
    /// The world-from-bind-space matrix of each joint.
    Posed(Vec<Affine3A>),
    /// Why it cannot be posed (a missing or non-finite joint).
    Broken(String),
}

/// The queries that pose skinned and morphed meshes.
#[derive(SystemParam)]
pub(super) struct Deformers<'w, 's> {
    skins: Query<'w, 's, Ref<'static, SkinnedMesh>>,
    joints: Query<'w, 's, Ref<'static, GlobalTransform>>,
    bindposes: Res<'w, Assets<SkinnedMeshInverseBindposes>>,
    bindpose_events: MessageReader<'w, 's, AssetEvent<SkinnedMeshInverseBindposes>>,
    mesh_weights: Query<'w, 's, (Entity, Ref<'static, MeshMorphWeights>)>,
    weights: Query<'w, 's, (Entity, Ref<'static, MorphWeights>)>,
    /// The weights last seen per entity: a paused animation writes the same ones every frame.
    seen: Local<'s, HashMap<Entity, Vec<f32>>>,
}

impl Deformers<'_, '_> {
    /// Whether a skin, a joint of one, an inverse bind pose or a morph weight changed.
    pub(super) fn changed(&mut self) -> bool {
        let joint_moved = self.skins.iter().any(|skin| {
            skin.is_changed()
                || skin
                    .joints
                    .iter()
                    .any(|&j| self.joints.get(j).is_ok_and(|t| t.is_changed()))
        });
        let mut weighed = self
            .mesh_weights
            .iter()
            .any(|(_, w)| w.is_changed() && matches!(*w, MeshMorphWeights::Reference(_)));
        let written = self
            .mesh_weights
            .iter()
            .filter(|(_, w)| w.is_changed())
            .filter_map(|(e, w)| match w.into_inner() {
                MeshMorphWeights::Value { weights } => Some((e, weights.as_slice())),
                MeshMorphWeights::Reference(_) => None,
            })
            .chain(
                self.weights
                    .iter()
                    .filter(|(_, w)| w.is_changed())
                    .map(|(e, w)| (e, w.into_inner().weights())),
            );
        for (entity, weights) in written {
            if self.seen.get(&entity).is_none_or(|seen| seen != weights) {
                self.seen.insert(entity, weights.to_vec());
                weighed = true;
            }
        }
        joint_moved || weighed || self.bindpose_events.read().count() > 0
    }

    /// `entity`'s skin, posed.
    pub(super) fn skin(&self, entity: Entity) -> Skin {
        let Ok(skin) = self.skins.get(entity) else {
            return Skin::None;
        };
        // Its load event extracts again.
        let Some(bindposes) = self.bindposes.get(&skin.inverse_bindposes) else {
            return Skin::Loading;
        };
        match self.joint_matrices(&skin, bindposes) {
            Ok(joints) => Skin::Posed(joints),
            Err(reason) => Skin::Broken(reason),
        }
    }

    fn joint_matrices(
        &self,
        skin: &SkinnedMesh,
        bindposes: &SkinnedMeshInverseBindposes,
    ) -> Result<Vec<Affine3A>, String> {
        if bindposes.len() < skin.joints.len() {
            return Err(format!(
                "{} joints but {} inverse bind poses",
                skin.joints.len(),
                bindposes.len()
            ));
        }
        skin.joints
            .iter()
            .zip(bindposes.iter())
            .map(|(&joint, bindpose)| {
                let world = self
                    .joints
                    .get(joint)
                    .map_err(|_| format!("joint {joint} has no GlobalTransform"))?;
                let matrix = world.affine() * Affine3A::from_mat4(*bindpose);
                if matrix.is_finite() {
                    Ok(matrix)
                } else {
                    Err(format!("joint {joint} has a non-finite transform"))
                }
            })
            .collect()
    }

    /// The morph weights of `entity`'s mesh (empty: none).
    pub(super) fn morph_weights(&self, entity: Entity) -> &[f32] {
        match self.mesh_weights.get(entity).map(|(_, w)| w.into_inner()) {
            Ok(MeshMorphWeights::Value { weights }) => weights,
            Ok(&MeshMorphWeights::Reference(source)) => self
                .weights
                .get(source)
                .map_or(&[], |(_, w)| w.into_inner().weights()),
            Err(_) => &[],
        }
    }
}
