//! The spectral renderer: physics against closed forms, scenes (TOML, RADIANCE, meshes), materials, lights, standard errors, images and their files (EXR read by OpenEXR's own reader), hostile scene files.
//!
//! One test crate (`cargo test --release --test render`); each module below
//! was its own crate before, and keeps its file and its tests' names
//! (`cargo test --release --test render <module>::`).

#[path = "../common/mod.rs"]
mod common;

mod camera_image;
mod converged_cache;
mod cornell_box;
mod exr_python;
mod fixed_seed_pins;
mod glossy_booth;
mod glossy_materials;
mod image_codings;
mod radiance_import;
mod reflectance_booth;
mod render_area_lights;
mod render_cancel;
mod render_cli_output;
mod render_defaults;
mod render_images;
mod render_meshes;
mod render_physics;
mod render_scenes;
mod render_standard_errors;
mod scene_input_limits;
