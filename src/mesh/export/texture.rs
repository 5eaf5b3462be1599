//! A layer's texture as exported: only the pixels its mesh uses, so that the objects of a sparse
//! layer do not carry their whole canvas. The triangles are grouped into *regions* (triangles
//! whose pixel boxes touch), each region's bounding box is cut out — on an equirect canvas a box
//! may run across the seam — and the boxes are packed into one texture, shelf by shelf. Texture
//! coordinates are moved into the packed boxes, so they stay in [0, 1] and the sampler clamps.
//! A region that goes round the whole equirect circle (a background, a sky, an object under the
//! pole) keeps the full width: the texture is then exactly as wide as the canvas, that region's
//! box sits at its left edge, and its seam copies keep `u` past 1 (a repeating sampler).

use super::{colour_rgb8, ExportMesh};
use crate::layer::LayerImage;

/// Pixels kept around the ones vertices sit in (pixel `floor(u·w)`), for bilinear filtering at
/// the crop's edges.
const MARGIN: i64 = 1;

/// An 8-bit sRGB texture ready to encode.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Row-major sRGB bytes, 3 per pixel (`R, G, B`), top row first.
    pub rgb: Vec<u8>,
    /// Whether texture coordinates rely on wrapping across `u = 1` (the sampler must repeat).
    pub wraps: bool,
}

/// A box of canvas pixels: columns `x0 .. x0 + w` (modulo the width on an equirect canvas), rows
/// `y0 .. y0 + h`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Box2 {
    x0: i64,
    y0: i64,
    w: i64,
    h: i64,
}

/// Crop `image`'s colour to the regions `mesh` uses and move the mesh's texture coordinates into
/// the packed texture.
pub fn crop(image: &LayerImage, mesh: &mut ExportMesh) -> Texture {
    let (w, h) = (image.width as i64, image.height as i64);
    let full = colour_rgb8(image);
    if mesh.triangles.is_empty() || w == 0 || h == 0 {
        return Texture { width: w as u32, height: h as u32, rgb: full, wraps: true };
    }
    let circular = w == 2 * h;
    let face = if 2 * w == 3 * h { Some(h / 2) } else { None };
    let px = |uv: [f32; 2]| (f64::from(uv[0]) * w as f64, f64::from(uv[1]) * h as f64);
    let boxes: Vec<Box2> = mesh
        .triangles
        .iter()
        .map(|t| triangle_box(t.map(|v| px(mesh.uvs[v as usize])), w, h, face))
        .collect();
    let (region_of, regions) = regions(&boxes, w, h, circular);
    // A region round the whole circle (`w` columns from 0) fixes the texture's width to the canvas's.
    let wraps = regions.iter().any(|b| circular && b.w == w);
    let (origins, tw, th) = shelf_pack(&regions, wraps.then_some(w));
    let mut vertex_region = vec![usize::MAX; mesh.uvs.len()];
    for (t, &r) in mesh.triangles.iter().zip(&region_of) {
        for &v in t {
            vertex_region[v as usize] = r;
        }
    }
    for (uv, &r) in mesh.uvs.iter_mut().zip(&vertex_region) {
        let Some(b) = regions.get(r) else { continue };
        let (x, y) = px(*uv);
        let dx = if circular && b.w < w { (x - b.x0 as f64).rem_euclid(w as f64) } else { x - b.x0 as f64 };
        uv[0] = ((dx + origins[r].0 as f64) / tw as f64) as f32;
        uv[1] = ((y - b.y0 as f64 + origins[r].1 as f64) / th as f64) as f32;
    }
    let mut rgb = vec![0u8; (3 * tw * th) as usize];
    for (b, &(ox, oy)) in regions.iter().zip(&origins) {
        for y in 0..b.h {
            for x in 0..b.w {
                let src = 3 * ((b.y0 + y) * w + (b.x0 + x).rem_euclid(w)) as usize;
                let dst = 3 * ((oy + y) * tw + ox + x) as usize;
                rgb[dst..dst + 3].copy_from_slice(&full[src..src + 3]);
            }
        }
    }
    Texture { width: tw as u32, height: th as u32, rgb, wraps }
}

/// The pixel box a triangle's bilinear lookups read: its vertices' pixels with the margin, inside
/// the canvas rows, and inside its cube face on a cube map (every triangle lies on one face).
/// Columns are not wrapped here (`x0` may be past the width after a seam copy).
fn triangle_box(p: [(f64, f64); 3], w: i64, h: i64, face: Option<i64>) -> Box2 {
    let fold = |f: fn(f64, f64) -> f64, init: f64, k: usize| {
        p.iter().map(|q| if k == 0 { q.0 } else { q.1 }).fold(init, f)
    };
    let (mut x0, mut x1) = (
        fold(f64::min, f64::INFINITY, 0).floor() as i64 - MARGIN,
        fold(f64::max, f64::NEG_INFINITY, 0).floor() as i64 + MARGIN + 1,
    );
    let (mut y0, mut y1) = (
        fold(f64::min, f64::INFINITY, 1).floor() as i64 - MARGIN,
        fold(f64::max, f64::NEG_INFINITY, 1).floor() as i64 + MARGIN + 1,
    );
    let (mut lo, mut hi) = ((i64::MIN, 0), (i64::MAX, h));
    if let Some(n) = face {
        let (s, t) = ((p[0].0 as i64 / n).clamp(0, 2), (p[0].1 as i64 / n).clamp(0, 1));
        lo = (s * n, t * n);
        hi = (s * n + n, t * n + n);
    } else if w != 2 * h {
        (lo.0, hi.0) = (0, w);
    }
    x0 = x0.max(lo.0);
    x1 = x1.min(hi.0).max(x0 + 1);
    // Coordinates outside the canvas (not made by `prepare`) stay inside it.
    y0 = y0.clamp(lo.1, hi.1 - 1);
    y1 = y1.min(hi.1).max(y0 + 1);
    Box2 { x0, y0, w: x1 - x0, h: y1 - y0 }
}

/// Group triangles whose boxes share a pixel (union-find over a label grid) and bound each group.
/// Returns each triangle's region and the regions; one that goes round the circle is all `w`
/// columns from 0.
fn regions(boxes: &[Box2], w: i64, h: i64, circular: bool) -> (Vec<usize>, Vec<Box2>) {
    let mut parent: Vec<usize> = (0..boxes.len()).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    let mut label = vec![u32::MAX; (w * h) as usize];
    for (t, b) in boxes.iter().enumerate() {
        for y in b.y0..b.y0 + b.h {
            for x in b.x0..b.x0 + b.w.min(w) {
                let cell = &mut label[(y * w + x.rem_euclid(w)) as usize];
                if *cell != u32::MAX {
                    let (a, c) = (root(&mut parent, *cell as usize), root(&mut parent, t));
                    parent[a] = c;
                }
                *cell = t as u32;
            }
        }
    }
    let mut index = vec![usize::MAX; boxes.len()];
    let mut members: Vec<Vec<usize>> = Vec::new();
    let mut region_of = Vec::with_capacity(boxes.len());
    for t in 0..boxes.len() {
        let r = root(&mut parent, t);
        if index[r] == usize::MAX {
            index[r] = members.len();
            members.push(Vec::new());
        }
        members[index[r]].push(t);
        region_of.push(index[r]);
    }
    let mut out = Vec::with_capacity(members.len());
    for m in &members {
        let y0 = m.iter().map(|&t| boxes[t].y0).min().unwrap_or(0);
        let y1 = m.iter().map(|&t| boxes[t].y0 + boxes[t].h).max().unwrap_or(1);
        let (x0, cw) = if circular {
            let arcs: Vec<(i64, i64)> = m.iter().map(|&t| (boxes[t].x0.rem_euclid(w), boxes[t].w)).collect();
            arc_cover(arcs, w).unwrap_or((0, w))
        } else {
            let x0 = m.iter().map(|&t| boxes[t].x0).min().unwrap_or(0);
            (x0, m.iter().map(|&t| boxes[t].x0 + boxes[t].w).max().unwrap_or(x0 + 1) - x0)
        };
        out.push(Box2 { x0, y0, w: cw, h: y1 - y0 });
    }
    (region_of, out)
}

/// The shortest arc `(start, length)` of the circle of `w` columns holding every arc `(start,
/// length)` given: the complement of the widest gap between them. `None` if they cover it all.
fn arc_cover(arcs: Vec<(i64, i64)>, w: i64) -> Option<(i64, i64)> {
    // Two turns of the circle, so that every gap lies whole between two consecutive runs.
    let mut spans: Vec<(i64, i64)> =
        arcs.iter().flat_map(|&(s, len)| [(s, s + len), (s + w, s + w + len)]).collect();
    spans.sort_unstable();
    let mut runs: Vec<(i64, i64)> = Vec::new();
    for (a, b) in spans {
        match runs.last_mut() {
            Some(last) if a <= last.1 => last.1 = last.1.max(b),
            _ => runs.push((a, b)),
        }
    }
    let (gap, next) = runs.windows(2).map(|r| (r[1].0 - r[0].1, r[1].0)).max_by_key(|&(g, n)| (g, -n))?;
    Some((next.rem_euclid(w), w - gap))
}

/// Place boxes on shelves (tallest first) in a texture about as wide as it is high, or exactly
/// `width` wide; returns each box's origin and the texture size.
fn shelf_pack(boxes: &[Box2], width: Option<i64>) -> (Vec<(i64, i64)>, i64, i64) {
    let area: i64 = boxes.iter().map(|b| b.w * b.h).sum();
    let widest = boxes.iter().map(|b| b.w).max().unwrap_or(1);
    let limit = width.unwrap_or_else(|| widest.max((area as f64 * 1.15).sqrt().ceil() as i64));
    let mut order: Vec<usize> = (0..boxes.len()).collect();
    order.sort_by_key(|&k| (std::cmp::Reverse(boxes[k].h), k));
    let mut origins = vec![(0, 0); boxes.len()];
    let (mut x, mut y, mut shelf, mut used_w) = (0i64, 0i64, 0i64, 0i64);
    for k in order {
        let b = boxes[k];
        if x + b.w > limit {
            y += shelf;
            (x, shelf) = (0, 0);
        }
        origins[k] = (x, y);
        x += b.w;
        shelf = shelf.max(b.h);
        used_w = used_w.max(x);
    }
    (origins, width.unwrap_or(used_w.max(1)), (y + shelf).max(1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layer::SampleType;

    fn image(w: usize, h: usize) -> LayerImage {
        let mut img = LayerImage::new(w, h);
        // Each pixel's red code is its column, green its row: the crop can be checked pixel by pixel.
        let code = |c: usize| crate::colour::srgb_to_linear(c as f32 / 255.0);
        img.set_channel("R", SampleType::F32, (0..w * h).map(|i| code(i % w)).collect());
        img.set_channel("G", SampleType::F32, (0..w * h).map(|i| code(i / w)).collect());
        img.set_channel("B", SampleType::F32, vec![0.0; w * h]);
        img
    }

    /// One triangle with its texture coordinates given in pixels.
    fn mesh(w: usize, h: usize, px: &[[f32; 2]]) -> ExportMesh {
        ExportMesh {
            positions: vec![[0.0; 3]; px.len()],
            uvs: px.iter().map(|p| [p[0] / w as f32, p[1] / h as f32]).collect(),
            colours: vec![[0.0; 3]; px.len()],
            triangles: (0..px.len() as u32 / 3).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect(),
            canvas_uvs: Vec::new(),
        }
    }

    /// The crop of a `w × h` image under [`mesh`]`(w, h, px)`, and the mesh with its new coordinates.
    fn cropped(w: usize, h: usize, px: &[[f32; 2]]) -> (Texture, ExportMesh) {
        let mut m = mesh(w, h, px);
        (crop(&image(w, h), &mut m), m)
    }

    /// Each vertex `k` shows texel `want` of the original image in the crop.
    fn texels_are(t: &Texture, m: &ExportMesh, want: &[(usize, (u8, u8))]) {
        for &(k, want) in want {
            assert_eq!(texel(t, m.uvs[k]), want, "vertex {k}");
        }
    }

    /// The texel the cropped texture shows at a vertex: the same (column, row) codes as before.
    fn texel(t: &Texture, uv: [f32; 2]) -> (u8, u8) {
        let (x, y) = ((uv[0] * t.width as f32) as usize, (uv[1] * t.height as f32) as usize);
        let i = 3 * (y.min(t.height as usize - 1) * t.width as usize + x.min(t.width as usize - 1));
        (t.rgb[i], t.rgb[i + 1])
    }

    #[test]
    fn a_small_object_keeps_only_its_pixels() {
        let (t, m) = cropped(64, 32, &[[10.5, 5.5], [14.5, 5.5], [10.5, 9.5]]);
        assert_eq!((t.width, t.height, t.wraps), (7, 7, false));
        texels_are(&t, &m, &[(1, (14, 5)), (2, (10, 9))]);
    }

    #[test]
    fn an_object_on_the_seam_is_one_crop_across_it() {
        // One triangle across the seam (u past 1, as `prepare` writes it), one just left of it.
        let (t, m) =
            cropped(64, 32, &[[62.5, 3.5], [65.5, 3.5], [62.5, 6.5], [58.5, 3.5], [61.5, 3.5], [58.5, 5.5]]);
        assert!(!t.wraps && t.width == 10, "{}x{}", t.width, t.height);
        texels_are(&t, &m, &[(1, (1, 3)), (3, (58, 3))]);
        assert!(m.uvs.iter().all(|uv| (0.0..=1.0).contains(&uv[0])));
    }

    #[test]
    fn separate_objects_are_separate_boxes() {
        // Two objects half the canvas apart: packed, they take their own pixels, not the span between.
        let (t, m) = cropped(
            256,
            128,
            &[[10.5, 60.5], [20.5, 60.5], [10.5, 70.5], [140.5, 90.5], [150.5, 90.5], [140.5, 95.5]],
        );
        assert!(!t.wraps && t.width * t.height <= 2 * 13 * 13, "{}x{}", t.width, t.height);
        let want =
            [(0, (10, 60)), (1, (20, 60)), (2, (10, 70)), (3, (140, 90)), (4, (150, 90)), (5, (140, 95))];
        texels_are(&t, &m, &want);
    }

    #[test]
    fn a_layer_round_the_whole_circle_keeps_the_width_and_wraps() {
        let img = image(64, 32);
        let tris: Vec<[f32; 2]> = (0..8)
            .flat_map(|k| {
                let x = 8.0 * k as f32 + 0.5;
                [[x, 20.5], [x + 9.0, 20.5], [x, 24.5]]
            })
            .collect();
        // The last of them crosses the seam (u past 1); and a small object above, apart.
        let mut tris = tris;
        tris.extend([[30.5, 3.5], [33.5, 3.5], [30.5, 5.5]]);
        let mut m = mesh(64, 32, &tris);
        let before = m.uvs.clone();
        let t = crop(&img, &mut m);
        assert_eq!((t.width, t.wraps), (64, true));
        assert_eq!(t.height, 7 + 5, "rows 19..=25 and 2..=6 only");
        assert!(m.uvs[..24].iter().zip(&before).all(|(a, b)| a[0] == b[0]), "the round region keeps its u");
        assert!(m.uvs[22][0] > 1.0, "the seam copy keeps u past 1");
        texels_are(&t, &m, &[(2, (0, 24)), (25, (33, 3))]);
    }

    #[test]
    fn a_cube_map_is_cropped_face_by_face() {
        // One triangle on face 4 (column 1, row 1), one on face 0 (column 0, row 0).
        let (t, m) =
            cropped(96, 64, &[[40.5, 40.5], [44.5, 40.5], [40.5, 50.5], [3.5, 3.5], [6.5, 3.5], [3.5, 5.5]]);
        // Face 0 keeps columns 2..=7 and rows 2..=6 (6 × 5), face 4 columns 39..=45 and rows
        // 39..=51 (7 × 13), packed on two shelves.
        assert_eq!((t.width, t.height, t.wraps), (7, 13 + 5, false));
        texels_are(&t, &m, &[(0, (40, 40)), (2, (40, 50)), (3, (3, 3)), (4, (6, 3)), (5, (3, 5))]);
        // A vertex next to a face edge: the margin stays inside the face.
        let (t, m) = cropped(96, 64, &[[32.5, 0.5], [35.5, 0.5], [32.5, 3.5]]);
        assert_eq!((t.width, t.height), (5, 5));
        assert_eq!(texel(&t, m.uvs[0]), (32, 0));
    }
}
