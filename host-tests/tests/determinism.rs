//! Determinism: an image is a pure function of (scene, size, spp, seed):
//! identical bytes across runs and thread counts, and different seeds give
//! different noise.

use micropt::Options;
use micropt_host::reference::scenes_dir;
use micropt_host::render::{RenderJob, load_scene, render};

fn pfm_bytes(scene: &str, spp: u32, seed: u64, threads: usize) -> Vec<u8> {
    let s = load_scene(&scenes_dir().join(scene)).unwrap();
    let (w, h) = s.resolution().unwrap();
    let out = render(
        &s,
        &RenderJob {
            width: w,
            height: h,
            spp,
            seed,
            threads,
            options: Options::default(),
        },
        &|| {},
    )
    .unwrap();
    assert_eq!(out.threads, threads.max(1));
    let mut bytes = Vec::new();
    out.image.write_pfm(&mut bytes).unwrap();
    bytes
}

#[test]
fn same_inputs_give_identical_bytes() {
    for scene in ["cornell.scene", "smallpt.scene"] {
        assert_eq!(
            pfm_bytes(scene, 4, 7, 2),
            pfm_bytes(scene, 4, 7, 2),
            "{scene}"
        );
    }
}

#[test]
fn thread_count_does_not_change_a_bit() {
    for scene in ["cornell.scene", "spheres.scene"] {
        let one = pfm_bytes(scene, 4, 3, 1);
        assert_eq!(one, pfm_bytes(scene, 4, 3, 2), "{scene}: 1 vs 2 threads");
        assert_eq!(one, pfm_bytes(scene, 4, 3, 3), "{scene}: 1 vs 3 threads");
    }
}

#[test]
fn seeds_change_the_noise() {
    assert_ne!(
        pfm_bytes("cornell.scene", 2, 1, 2),
        pfm_bytes("cornell.scene", 2, 2, 2)
    );
}
