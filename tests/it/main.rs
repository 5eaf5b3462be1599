//! The integration tests, one binary (one link of the library instead of one per file); each
//! module is one concern. `tests/convert_memory.rs` stays apart: its counting allocator must see
//! no other test.

mod build_conventions;
mod build_room;
mod convert_resample;
mod exr_interop;
mod fixtures_room;
mod manifest_codes;
mod manifest_props;
mod manifest_thesis;
mod mapping_sweeps;
mod mesh_export;
mod mesh_figures;
mod mesh_robust;
mod mesh_room;
mod pack_roundtrip;
mod prepare_depth;
mod render_mesh;
mod render_room;
mod render_stereo;
mod scene_layers;
mod source_layout;
mod validate_codes;
