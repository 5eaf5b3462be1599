//! What a hit looks like: the material's base colour (texture × factor × vertex colour) plus its
//! emission, linear; no lighting is computed (a lit scene comes with its light baked into textures).

use glam::{Vec2, Vec3, Vec4};

use crate::colour::srgb_to_linear;

/// How texture coordinates outside `[0, 1]` wrap.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Wrap {
    /// Repeat (glTF's default).
    #[default]
    Repeat,
    /// Clamp to the edge texel.
    Clamp,
    /// Repeat mirrored.
    Mirror,
}

/// A texture used by a material.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TextureRef {
    /// Index into [`TriangleScene::textures`].
    pub texture: u32,
    /// Wrap along u and v.
    pub wrap: [Wrap; 2],
    /// Texture coordinate set.
    pub uv_set: u32,
}

/// A surface's material.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Base colour factor, linear RGBA.
    pub base: Vec4,
    /// Base colour texture (sRGB).
    pub base_texture: Option<TextureRef>,
    /// Emitted colour factor, linear (times the emissive strength).
    pub emissive: Vec3,
    /// Emissive texture (sRGB).
    pub emissive_texture: Option<TextureRef>,
    /// Whether the back side is seen (glTF `doubleSided`; always for OBJ).
    pub double_sided: bool,
}

impl Default for Material {
    fn default() -> Self {
        Material {
            base: Vec4::ONE,
            base_texture: None,
            emissive: Vec3::ZERO,
            emissive_texture: None,
            double_sided: false,
        }
    }
}

impl Material {
    /// Whether a texture colours the surface (its colour varies within a pixel).
    pub fn textured(&self) -> bool {
        self.base_texture.is_some() || self.emissive_texture.is_some()
    }

    /// The texture coordinate set the material reads (the base colour texture's).
    pub fn uv_set(&self) -> u32 {
        self.base_texture.or(self.emissive_texture).map_or(0, |t| t.uv_set)
    }
}

/// An 8-bit sRGB RGBA texture (alpha linear).
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    width: usize,
    height: usize,
    texels: Vec<[u8; 4]>,
}

impl Texture {
    /// A texture of `width × height` texels, rows top first; an empty or short one reads white.
    pub fn new(width: usize, height: usize, texels: Vec<[u8; 4]>) -> Texture {
        if width == 0 || height == 0 || texels.len() < width * height {
            return Texture { width: 1, height: 1, texels: vec![[255; 4]] };
        }
        Texture { width, height, texels }
    }

    /// Bilinear sample at texture coordinates `uv` (`v` down), linear RGBA.
    pub fn sample(&self, uv: Vec2, wrap: [Wrap; 2]) -> Vec4 {
        let x = uv.x * self.width as f32 - 0.5;
        let y = uv.y * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let texel = |i: f32, j: f32| {
            let i = wrap_index(i, self.width, wrap[0]);
            let j = wrap_index(j, self.height, wrap[1]);
            let t = self.texels[j * self.width + i];
            let lut = srgb_lut();
            Vec4::new(lut[t[0] as usize], lut[t[1] as usize], lut[t[2] as usize], t[3] as f32 / 255.0)
        };
        let top = texel(x0, y0).lerp(texel(x0 + 1.0, y0), fx);
        let bottom = texel(x0, y0 + 1.0).lerp(texel(x0 + 1.0, y0 + 1.0), fx);
        top.lerp(bottom, fy)
    }
}

/// sRGB 8-bit code to linear, every code once.
fn srgb_lut() -> &'static [f32; 256] {
    static LUT: std::sync::OnceLock<[f32; 256]> = std::sync::OnceLock::new();
    LUT.get_or_init(|| std::array::from_fn(|i| srgb_to_linear(i as f32 / 255.0)))
}

/// Texel index `i` (may be out of range or not finite) wrapped into `0..n`.
fn wrap_index(i: f32, n: usize, wrap: Wrap) -> usize {
    if !i.is_finite() {
        return 0;
    }
    let i = i.clamp(-1e9, 1e9) as i64;
    let n = n as i64;
    let k = match wrap {
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::Clamp => i.clamp(0, n - 1),
        Wrap::Mirror => {
            let m = i.rem_euclid(2 * n);
            if m < n {
                m
            } else {
                2 * n - 1 - m
            }
        }
    };
    k as usize
}
