//! Tests of the segmentation: levels, specks and the splits of self-occluding segments.

use super::*;
use crate::mapping::{AnyMapping, MappingKind};

/// A distant building (mean 23 m) occludes the ground (mean 8 m: mostly near the camera): with no
/// cycle the relation counts, so the building is a level above the ground.
#[test]
fn far_occluder_of_a_nearer_on_average_surface_is_promoted() {
    let mean = [8.0, 23.0];
    let level = levels(2, &mean, &[1000, 50], &[(1, 0, 30)], &HashMap::new(), &[30, 30]);
    assert_eq!(level, vec![0, 1]);
}

/// A cycle A → B → C → A is broken by mean depth (far to near); a segment outside the cycle
/// that occludes one of it stacks above the whole chain.
#[test]
fn cycles_are_broken_by_mean_depth_only_inside_the_cycle() {
    // Means: 0 far (10 m), 1 middle (5 m), 2 near (2 m); 3 occludes 2 but is farther (12 m).
    let mean = [10.0, 5.0, 2.0, 12.0];
    let occ = [(1, 0, 9), (2, 1, 9), (0, 2, 9), (3, 2, 9)];
    let level = levels(4, &mean, &[9; 4], &occ, &HashMap::new(), &[18, 18, 27, 9]);
    // Inside the cycle only near → far survive: 2 → 1 → 0 (0 → 2 dropped).
    assert_eq!(&level[..3], &[0, 1, 2]);
    assert_eq!(level[3], 3);
    let comp = strong_components(&[vec![1], vec![2], vec![0], vec![2]]);
    assert!(comp[0] == comp[1] && comp[1] == comp[2] && comp[3] != comp[0]);
}

/// A lamp's face (30 000 px) whose rim the settle kept at the lamp's depth as a ring of its own
/// (2 700 px, a fold from the face, a jump to the ceiling) occludes nothing itself: ringed by its
/// rim, it goes up with it although the rim is smaller. The floor a box stands on (its border
/// mostly walls, which are free) does not follow the smaller box.
#[test]
fn a_face_ringed_by_its_rim_takes_the_rims_level() {
    // 0 ceiling and walls, 1 rim, 2 lamp face, 3 floor, 4 box.
    let mean = [3.0, 1.12, 1.10, 2.0, 1.5];
    let size = [400_000, 2_700, 30_000, 100_000, 5_000];
    let occ = [(1, 0, 900), (4, 0, 60)];
    let folds = HashMap::from([((1, 2), 1_000), ((0, 3), 2_000), ((3, 4), 300)]);
    // Borders: the lamp's is its rim; the floor's mostly walls.
    let border = [2_960, 1_900, 1_000, 2_300, 360];
    let level = levels(5, &mean, &size, &occ, &folds, &border);
    assert_eq!(level, vec![0, 1, 1, 0, 1]);
    // Without the ring all round (half its border to something else), the face stays.
    let level = levels(5, &mean, &size, &occ, &folds, &[2_960, 1_900, 2_000, 2_300, 360]);
    assert_eq!(level[2], 0);
}

/// Noise leaves fields of small free pieces on a surface, each mostly bordered by the others: they
/// do not ring one another (their levels are not settled) but follow the surface they lie on.
#[test]
fn free_pieces_do_not_ring_one_another() {
    // 0 wall, 1 object in front of it, 2 a patch folded to the object, 3 and 4 pieces on the patch.
    let mean = [4.0, 2.0, 2.1, 2.1, 2.1];
    let size = [100_000, 50_000, 5_000, 2, 1];
    let folds = HashMap::from([((1, 2), 400), ((2, 3), 2), ((3, 4), 6)]);
    let border = [900, 1_300, 402, 8, 6];
    let level = levels(5, &mean, &size, &[(1, 0, 900)], &folds, &border);
    assert_eq!(level, vec![0, 1, 1, 1, 1]);
}

/// A wall (100 000 px) with a 12-pixel speck of something farther behind it stays the
/// background; a box in front of the wall is still a level up.
#[test]
fn a_speck_behind_a_surface_does_not_lift_it() {
    let mean = [4.0, 4.5, 2.0];
    let size = [100_000, 12, 5_000];
    let level = levels(3, &mean, &size, &[(0, 1, 5), (2, 0, 40)], &HashMap::new(), &[45, 5, 40]);
    assert_eq!(level[0], 0);
    assert_eq!(level[2], 1);
}

/// A disc 1 m away in front of a wall 4 m away, its depth blurred (σ = 1 px): the outline is a
/// rim of in-between depths whose pixels form slivers, specks beside the disc, so no border of
/// three jumps joins disc and wall. The disc is ordered in front of the wall all the same.
#[test]
fn an_object_behind_a_rim_of_slivers_is_in_front() {
    let (w, h) = (256usize, 128usize);
    let m = AnyMapping::new(MappingKind::Equirect, w, h).unwrap();
    let nb = Neighbours::new(m);
    let sharp = |x: i32, y: i32| if (x - 128).pow(2) + (y - 64).pow(2) < 900 { 1.0 } else { 4.0 };
    let kernel: Vec<f32> = (-3..=3).map(|d: i32| (-0.5 * (d * d) as f32).exp()).collect();
    let total: f32 = kernel.iter().sum::<f32>().powi(2);
    let depth: Vec<f32> = (0..w * h)
        .map(|p| {
            let (x, y) = ((p % w) as i32, (p / w) as i32);
            let mut sum = 0.0;
            for (i, kx) in kernel.iter().enumerate() {
                for (j, ky) in kernel.iter().enumerate() {
                    sum += kx * ky * sharp(x + i as i32 - 3, y + j as i32 - 3);
                }
            }
            sum / total
        })
        .collect();
    let o = SegmentOptions::default();
    let links = Links::compute(&nb, &depth, &o.edges);
    let normals = vec![Vec3::X; w * h];
    let seg = segment(&nb, &depth, &links, &normals, &o);
    let level = |x: usize, y: usize| seg.level[seg.id[y * w + x] as usize];
    assert!(level(128, 64) > level(5, 5), "disc level {} wall level {}", level(128, 64), level(5, 5));
}

/// One flat surface (every normal alike) whose left half is 1 m away and right half 2 m: a
/// smooth ramp joins them in the top rows, a jump parts them below. The segment occludes
/// itself, but its sides meet only across flat surface, where a watershed cut would follow the
/// order ties are joined in: only its front pixels (along the jump) are cut off.
#[test]
fn a_cut_through_flat_surface_is_not_made() {
    let (w, h) = (64usize, 32usize);
    let m = AnyMapping::new(MappingKind::Equirect, w, h).unwrap();
    let nb = Neighbours::new(m);
    let depth: Vec<f32> = (0..w * h)
        .map(|p| {
            let (x, y) = (p % w, p / w);
            if y < h / 2 {
                1.0 + ((x as f32 - 16.0) / 32.0).clamp(0.0, 1.0)
            } else if x < w / 2 {
                1.0
            } else {
                2.0
            }
        })
        .collect();
    let o = SegmentOptions::default();
    let links = Links::compute(&nb, &depth, &o.edges);
    let normals = vec![Vec3::X; w * h];
    let seg = segment(&nb, &depth, &links, &normals, &o);
    let at = |x: usize, y: usize| seg.id[y * w + x];
    assert_eq!(at(10, 28), at(50, 28), "the two sides stay one surface");
    assert_ne!(at(31, 28), at(10, 28), "the front pixels along the jump are cut off");
}

/// Joining bands of rows in parallel gives the sets and roots of joining every link in order, on
/// both mappings (links across the seam, the poles and cube-face edges cross bands).
#[test]
fn banded_union_equals_serial_union() {
    for (kind, w, h) in [(MappingKind::Equirect, 64, 32), (MappingKind::Cube3x2, 96, 64)] {
        let nb = Neighbours::new(AnyMapping::new(kind, w, h).unwrap());
        // A fixed pseudo-random pattern of links, sparse enough to leave many sets.
        let mut state = 0x9E37_79B9u32;
        let masks: Vec<(u8, u8, u8)> = (0..nb.len())
            .map(|p| {
                state ^= state << 13;
                state ^= state >> 17;
                state ^= state << 5;
                let (x, y) = (p % w, p / w);
                let bits =
                    (0..4).filter(|&i| nb.get_at(x, y, HALF[i]).is_some() && state >> (8 * i) & 3 == 0);
                (bits.fold(0u8, |m, i| m | 1 << i), 0, 0)
            })
            .collect();
        let mut serial = Dsu::new(nb.len());
        for (p, &(smooth, _, _)) in masks.iter().enumerate() {
            for (i, &k) in HALF.iter().enumerate() {
                if smooth >> i & 1 == 1 {
                    serial.union(p as u32, nb.get(p, k).unwrap() as u32);
                }
            }
        }
        let mut banded = Dsu::of_smooth_links(&nb, &masks);
        let roots = |d: &mut Dsu| (0..nb.len() as u32).map(|p| d.find(p)).collect::<Vec<_>>();
        let (a, b) = (roots(&mut serial), roots(&mut banded));
        assert_eq!(a, b, "{kind:?}");
        let sets = a.iter().enumerate().filter(|&(p, &r)| p as u32 == r).count();
        assert!(sets > 10 && sets < nb.len() / 2, "{kind:?}: {sets} sets");
    }
}
