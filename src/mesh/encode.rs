//! The `.pomcmesh` encoding (spec/08-mesh.md): the quadtrees as breadth-first split bits, zstd-compressed.
//!
//! Only the tree is stored: vertex positions come from the layer's own depth (a vertex is a pixel
//! centre), and everything else — which nodes are empty, which cells are cut by a border or a jump,
//! hanging vertices, stitching — is a deterministic function of the tree and the layer. Decoding
//! therefore needs the layer and reproduces the encoder's triangles exactly.
//!
//! Layout: `"POMCMESH"`, version byte `1`, then one zstd frame holding: mapping (`0` equirect, `1` cube
//! 3×2), canvas width and height (`u32` LE), tree count (`u8`), for each tree its bit count (`u32` LE),
//! then each tree's bits packed most-significant first, padded to a byte.

use super::quadtree::Tree;
use super::subdivide::Criterion;
use super::{lattices, mesh_from_trees, LayerMesh, MeshError, MeshOptions};
use crate::layer::LayerImage;
use crate::mapping::{AnyMapping, Mapping};

/// First eight bytes of every `.pomcmesh` file.
pub const MAGIC: &[u8; 8] = b"POMCMESH";
/// Encoding version byte written after [`MAGIC`]; decoding rejects any other.
pub const VERSION: u8 = 1;
/// Conventional file extension.
pub const EXTENSION: &str = "pomcmesh";

fn mapping_code(m: &AnyMapping) -> u8 {
    match m {
        AnyMapping::Equirect(_) => 0,
        AnyMapping::Cube(_) => 1,
    }
}

/// Encode the trees of a mesh of a layer of `mapping`.
pub fn encode(trees: &[Option<Tree>], mapping: &AnyMapping) -> Result<Vec<u8>, MeshError> {
    let mut payload = vec![mapping_code(mapping)];
    payload.extend_from_slice(&(mapping.width() as u32).to_le_bytes());
    payload.extend_from_slice(&(mapping.height() as u32).to_le_bytes());
    payload.push(trees.len() as u8);
    let bits: Vec<Vec<bool>> = trees.iter().map(|t| t.as_ref().map(Tree::bits).unwrap_or_default()).collect();
    for b in &bits {
        payload.extend_from_slice(&(b.len() as u32).to_le_bytes());
    }
    for b in &bits {
        for chunk in b.chunks(8) {
            payload.push(chunk.iter().enumerate().fold(0u8, |acc, (i, &bit)| acc | ((bit as u8) << (7 - i))));
        }
    }
    // One-shot compression knows the input size, so level 19 sizes its tables to the (small) payload
    // instead of allocating for an unknown stream (tens of milliseconds).
    let z = zstd::bulk::compress(&payload, 19).map_err(|e| MeshError::Encoding(e.to_string()))?;
    let mut out = MAGIC.to_vec();
    out.push(VERSION);
    out.extend_from_slice(&z);
    Ok(out)
}

/// Cursor over the payload with typed errors.
struct Reader<'a> {
    b: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8], MeshError> {
        let s = self
            .b
            .get(self.at..self.at + n)
            .ok_or_else(|| MeshError::Encoding("truncated payload".into()))?;
        self.at += n;
        Ok(s)
    }
    fn u8(&mut self) -> Result<u8, MeshError> {
        Ok(self.take(1)?[0])
    }
    fn u32(&mut self) -> Result<u32, MeshError> {
        let s = self.take(4)?;
        Ok(u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
    }
}

/// Decode the split bits of every tree, checking them against `mapping`.
pub fn decode_bits(bytes: &[u8], mapping: &AnyMapping) -> Result<Vec<Vec<bool>>, MeshError> {
    let bad = |m: &str| MeshError::Encoding(m.to_string());
    if bytes.len() < 9 || &bytes[..8] != MAGIC {
        return Err(bad("not a pomcmesh file (bad magic)"));
    }
    if bytes[8] != VERSION {
        return Err(bad(&format!("unsupported version {}", bytes[8])));
    }
    // Bounded decompression: a tree has fewer bits than the canvas has pixels.
    let limit = 64 + 6 * 4 + mapping.width() * mapping.height() / 8 + 16;
    let mut payload = Vec::new();
    let mut dec = zstd::stream::read::Decoder::new(&bytes[9..]).map_err(|e| bad(&e.to_string()))?;
    std::io::Read::read_to_end(&mut std::io::Read::take(&mut dec, limit as u64 + 1), &mut payload)
        .map_err(|e| bad(&e.to_string()))?;
    if payload.len() > limit {
        return Err(bad("payload larger than the canvas allows"));
    }
    let mut r = Reader { b: &payload, at: 0 };
    let (code, w, h) = (r.u8()?, r.u32()? as usize, r.u32()? as usize);
    if code != mapping_code(mapping) || w != mapping.width() || h != mapping.height() {
        return Err(bad("the mesh was made for another canvas or mapping"));
    }
    let n = r.u8()? as usize;
    let expected = match mapping {
        AnyMapping::Equirect(_) => 1,
        AnyMapping::Cube(_) => 6,
    };
    if n != expected {
        return Err(bad("wrong number of trees"));
    }
    let counts: Vec<usize> = (0..n).map(|_| r.u32().map(|c| c as usize)).collect::<Result<_, _>>()?;
    let mut out = Vec::with_capacity(n);
    for c in counts {
        let bytes = r.take(c.div_ceil(8))?;
        out.push((0..c).map(|i| bytes[i / 8] >> (7 - i % 8) & 1 == 1).collect());
    }
    if r.at != payload.len() {
        return Err(bad("trailing bytes"));
    }
    Ok(out)
}

/// Decode a `.pomcmesh` against its layer: the same triangles the encoder's mesh had.
pub fn decode(bytes: &[u8], image: &LayerImage, mapping: &AnyMapping) -> Result<LayerMesh, MeshError> {
    let bits = decode_bits(bytes, mapping)?;
    let grids = lattices(image, mapping)?;
    let params = MeshOptions { feature_angle_deg: None, ..MeshOptions::quadtree() };
    let mut trees = Vec::with_capacity(grids.len());
    for (g, b) in grids.iter().zip(&bits) {
        let c = Criterion::new(g, image, &params);
        let tree = match Tree::root(g.w, g.h, &c) {
            None if b.is_empty() => None,
            None => return Err(MeshError::Encoding("bits for a lattice without cells".into())),
            Some(_) => Some(
                Tree::from_bits(g.w, g.h, &c, b)
                    .ok_or_else(|| MeshError::Encoding("split bits do not match the layer".into()))?,
            ),
        };
        trees.push(tree);
    }
    Ok(mesh_from_trees(&grids, &trees, mapping))
}
