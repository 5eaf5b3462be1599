//! # pomc — layered omnidirectional RGB-D panoramas
//!
//! A POMC (*panorama omnidirecional com múltiplas camadas*) is a set of layers over the sphere of
//! directions, each a continuous piece of surface (colour, distance along the ray, optional normals…).
//! This crate is the reference implementation of the POMC 1 format described in `spec/`.
//!
//! Module tree mirrors the format (`docs/api.md` has the table and what is public):
//! - [`mapping`]: pixel ↔ direction for the equirect and 3×2 cube-map parametrisations, neighbours;
//! - [`resample`]: sphere-aware sampling and equirect ↔ cube conversion ([`jobs::convert_file`]: of
//!   whole images, layer files and panoramas, `pomc convert`);
//! - [`manifest`]: the XML manifest (`panorama.xml`), with source positions for diagnostics;
//! - [`layer`]: in-memory layer images and the depth/coverage encodings;
//! - [`layer_io`]: reading and writing layer files (native EXR and the thesis PNG+EXR form);
//! - [`pack`]: patch-packed compression (patch table + atlas);
//! - [`panorama`]: a whole panorama directory (manifest + layers), written as a whole;
//! - [`validate`] and [`codes`]: the validator and its stable codes;
//! - [`prepare`]: the depth people have to the depth layering needs (spec §7.1);
//! - [`layering`]: layers from a plain RGB-D panorama (spec §7), the job `pomc build` runs;
//! - [`scene`]: layers from a 3D scene (glTF, OBJ) by tracing every hit (thesis 6.3.2, `pomc scene`);
//! - [`mesh`]: adaptive quadtree meshes and their export (spec §8);
//! - [`render`]: views from a displaced camera, by point splatting or mesh rasterisation (spec §9);
//! - [`viewer`]: the browser viewer's static site;
//! - [`image_io`] and [`colour`]: plain images in and out, sRGB ↔ linear at the edges;
//! - [`Raster`]: the plain interleaved image container;
//! - [`error`]: the crate's error type, each with a stable code;
//! - [`jobs`] and [`prelude`]: the main jobs, one call each, with the command line's defaults.

#![forbid(unsafe_code)]
#![warn(missing_docs)]
#![warn(unnameable_types)]

pub mod choice;
pub mod codes;
pub mod colour;
pub(crate) mod continuity;
pub mod error;
mod fsutil;
pub mod image_io;
pub mod input;
pub mod jobs;
pub mod layer;
pub mod layer_io;
pub mod layering;
pub mod manifest;
pub mod mapping;
pub mod mesh;
pub mod pack;
pub mod panorama;
pub mod prelude;
pub mod prepare;
mod raster;
pub mod render;
pub mod resample;
pub mod scene;
pub mod validate;
pub mod viewer;

pub use error::{Error, Result};
pub use raster::{Raster, RasterSizeError};
