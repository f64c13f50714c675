//! The cases: malformed, extreme and hostile glTF/GLB files, flags at their extremes, and
//! `compare` and `bench` inputs, each with what `rppm` must do with it.

mod flags;
mod numbers;
mod structure;

use serde_json::Value;

use super::scene::base;
use super::{Case, Expect};

pub use flags::flags;
pub use numbers::{big, numbers};
pub use structure::structure;

/// `rppm render` of the case's scene, small and short.
pub(super) fn render(scene: &str) -> Vec<String> {
    let small = "--width 32 --height 32 --iterations 2 --photons 4096 --out {dir}/out.exr";
    ["render".to_string(), format!("{{dir}}/{scene}")]
        .into_iter()
        .chain(small.split(' ').map(String::from))
        .collect()
}

pub(super) fn json_bytes(v: &Value) -> Vec<u8> {
    serde_json::to_vec(v).expect("JSON serialises")
}

/// The base scene changed by `edit`, rendered.
pub(super) fn edited(
    name: &str,
    group: &'static str,
    expect: Expect,
    edit: impl FnOnce(&mut Value),
) -> Case {
    let mut scene = base();
    edit(&mut scene);
    Case::new(
        name,
        group,
        vec![("scene.gltf".into(), json_bytes(&scene))],
        render("scene.gltf"),
        expect,
    )
}

/// Sets the value at a JSON pointer (which must exist up to its parent).
pub(super) fn set(v: &mut Value, pointer: &str, value: Value) {
    let (parent, key) = pointer.rsplit_once('/').expect("a pointer");
    let parent = v.pointer_mut(parent).unwrap_or_else(|| panic!("{pointer}"));
    match parent {
        Value::Array(items) => items[key.parse::<usize>().expect("an index")] = value,
        Value::Object(map) => {
            map.insert(key.to_string(), value);
        }
        _ => panic!("{pointer}"),
    }
}

pub(super) type Edit = Box<dyn FnOnce(&mut Value)>;

pub(super) fn error(text: &'static str) -> Expect {
    Expect::Error(text)
}
