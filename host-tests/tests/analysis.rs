//! The scene analysis on the shipped scenes and on small scenes built to
//! test one finding each: closed rooms, the planes and spheres that can
//! shadow a light, unreachable lights, the view order, the horizon tests.
//! (The analysis's own unit tests, which need no scene text, are next to
//! it in the core.)

use micropt::ObjectId;
use micropt::parse::parse;

#[test]
fn cornell_is_closed_and_its_walls_never_shadow() {
    let s = parse(include_str!("../../scenes/cornell.scene")).unwrap();
    let a = s.analysis();
    assert!(a.closed);
    assert!(a.shadow_planes.is_empty(), "{:?}", a.shadow_planes);
    // the matte and chrome spheres; the only light cannot block itself
    assert_eq!(a.shadow_spheres.as_slice(), &[1, 2]);
    // and neither reaches into the light
    assert!(a.light_clear);
    assert_eq!(a.lights.as_slice(), &[0]);
    // the six walls are the slabs: floor/ceiling (y), back/front (z),
    // left/right (x); no plane is left to test one by one
    assert_eq!(a.slabs.c, [[1.0, 0.0]; 3]);
    // [axis][0]: above the eye, [axis][1]: below
    assert_eq!(a.slabs.id[1], [ObjectId::plane(1), ObjectId::plane(0)]);
    assert_eq!(a.slabs.id[0], [ObjectId::plane(5), ObjectId::plane(4)]);
    assert_eq!(a.slabs.id[2], [ObjectId::plane(3), ObjectId::plane(2)]);
    assert!(a.other_planes.is_empty());
}

#[test]
fn open_scenes_are_not_closed() {
    for text in [
        include_str!("../../scenes/furnace.scene"),
        include_str!("../../scenes/spheres.scene"),
    ] {
        let s = parse(text).unwrap();
        assert!(!s.analysis().closed);
    }
    let s = parse(include_str!("../../scenes/sphere-over-plane.scene")).unwrap();
    assert!(!s.analysis().closed);
    // the light is above the floor: the floor never blocks it
    assert!(s.analysis().shadow_planes.is_empty());
}

#[test]
fn smallpt_is_closed_but_its_light_pokes_out() {
    let s = parse(include_str!("../../scenes/smallpt.scene")).unwrap();
    let a = s.analysis();
    assert!(a.closed);
    // the light (radius 600) reaches outside every wall sphere but the
    // floor's (whose ball, centred at y = 1e5, holds room and light):
    // only the floor can never block a light sample (and the light
    // cannot block itself)
    assert_eq!(a.shadow_spheres.as_slice(), &[0, 1, 2, 3, 5, 6, 7]);
    assert_eq!(a.lights.as_slice(), &[8]);
    // the light pokes through the ceiling sphere, an occluder
    assert!(!a.light_clear);
}

#[test]
fn unreachable_lights_are_dropped() {
    let s = parse(
        "camera 0 1 5 0 1 0 0 1 0 40\nmaterial g diffuse 0.5 0.5 0.5\nmaterial l light 1 1 1\n\
         plane 0 0 0 0 1 0 g\nsphere 0 -3 0 1 l\nsphere 0 3 0 1 l\n",
    )
    .unwrap();
    assert_eq!(s.analysis().lights.as_slice(), &[1]);
}

#[test]
fn view_keys_sort_spheres_by_visibility() {
    let s = parse(
        "camera 0 0 0 0 0 -1 0 1 0 40\nmaterial g diffuse 0.5 0.5 0.5\n\
         sphere 0 0 5 1 g\nsphere 0 0 -5 1 g\nsphere 5 0 -5 1 g\n",
    )
    .unwrap();
    let a = s.analysis();
    // on the axis first, then off-axis, then behind
    assert_eq!(a.view_order.as_slice(), &[1, 2, 0]);
    assert_eq!(a.view_keys[0], 2.0);
    assert!(a.view_keys[1] < 1.0 && a.view_keys[1] > 0.5);
    assert!(a.view_keys[2] < 0.0);
}

#[test]
fn horizon_tests_only_where_a_light_can_set() {
    // cornell: the light is inside the room, on the camera's side of
    // every wall; the matte sphere's underside faces away from it
    let a = parse(include_str!("../../scenes/cornell.scene"))
        .unwrap()
        .analysis()
        .clone();
    assert!(!a.horizon_planes && a.horizon_spheres);
    // sphere-over-plane: a plane and the light above it, no diffuse sphere
    let a = parse(include_str!("../../scenes/sphere-over-plane.scene"))
        .unwrap()
        .analysis()
        .clone();
    assert!(!a.horizon_planes && !a.horizon_spheres);
    // a light on the plane's far side from the camera can set below it
    let s = parse(
        "camera 0 -1 5 0 -1 0 0 1 0 40
material g diffuse 0.5 0.5 0.5
         material l light 1 1 1
plane 0 0 0 0 1 0 g
sphere 0 3 0 1 l
",
    )
    .unwrap();
    assert!(s.analysis().horizon_planes);
    // a light straddling the plane: conservatively tested
    let s = parse(
        "camera 0 1 5 0 1 0 0 1 0 40
material g diffuse 0.5 0.5 0.5
         material l light 1 1 1
plane 0 0 0 0 1 0 g
sphere 0 0.5 0 1 l
",
    )
    .unwrap();
    assert!(s.analysis().horizon_planes);
    // inside a diffuse dome that holds the light: never below the horizon
    let dome = "camera 0 0 0 0 0 -1 0 1 0 40
material g diffuse 0.5 0.5 0.5
                material l light 1 1 1
sphere 0 0 0 10 g
sphere 0 5 0 1 l
";
    let s = parse(dome).unwrap();
    assert!(!s.analysis().horizon_spheres);
    // the camera outside it: its far side can face away from the light
    let s = parse(&dome.replace("camera 0 0 0", "camera 0 0 20")).unwrap();
    assert!(s.analysis().horizon_spheres);
    // inside the dome with the light entirely outside it: it can set
    let s = parse(&dome.replace("sphere 0 5 0 1 l", "sphere 0 12 0 1 l")).unwrap();
    assert!(s.analysis().horizon_spheres);
    // smallpt: the camera is inside all six wall balls, and its lamp
    // pokes into each of them (0.27 units into the ceiling's)
    let a = parse(include_str!("../../scenes/smallpt.scene"))
        .unwrap()
        .analysis()
        .clone();
    assert!(!a.horizon_planes && !a.horizon_spheres);
}
