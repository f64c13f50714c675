//! What the `rppm` tool and the tests share: a headless Bevy app that renders glTF scenes
//! (posed by their animations),
//! image files and the metrics of `shared/docs/CONVENTIONS.md`, the speed/accuracy trade and
//! the deep-cubemap bench, the validation suite against Mitsuba 3, the checks of glTF input and what Bevy's loader
//! does not read of it.

pub mod animation;
pub mod bench;
pub mod catalogue;
pub mod extensions;
pub mod headless;
pub mod image_io;
pub mod load;
pub mod motion;
pub mod suite;
pub mod trade;
pub mod validate;
