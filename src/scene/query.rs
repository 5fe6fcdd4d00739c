//! How a ray finds its hit: the closest-hit and occlusion queries over a
//! borrowed [`SceneView`] of a scene and its analysis.

use super::bvh::BvhView;
use crate::analysis::{Listed, Slabs};
use crate::geometry::{Color, Hit, ObjectId, Plane, Ray, Sphere};
use crate::material::Material;
use crate::math;

/// The arrays of a [`Scene`](super::Scene) and its analysis, borrowed; ray queries live
/// here.
#[derive(Clone, Copy, Debug)]
pub struct SceneView<'a> {
    /// The spheres.
    pub spheres: &'a [Sphere],
    /// The planes.
    pub planes: &'a [Plane],
    /// The materials.
    pub materials: &'a [Material],
    /// Indices of reachable emitting spheres.
    pub lights: &'a [u16],
    /// Indices of all emitting spheres.
    pub emitters: &'a [u16],
    /// Spheres that can block a shadow ray.
    pub shadow_spheres: &'a [u16],
    /// Planes that can block a shadow ray.
    pub shadow_planes: &'a [u16],
    /// Spheres a camera ray can hit.
    pub primary_spheres: &'a [u16],
    /// The walls tested one per axis ([`Slabs`]); `None` when the scene has
    /// no opaque axis-aligned plane.
    pub slabs: Option<Slabs>,
    /// The planes that are not in `slabs`.
    pub other_planes: &'a [u16],
    /// The spheres (copies with their ids) that bounce rays test, in the
    /// analysis' view order.
    pub tested: &'a [Listed],
    /// The spheres that camera rays test (`primary_spheres`).
    pub tested_primary: &'a [Listed],
    /// The spheres that shadow rays test (`shadow_spheres`).
    pub tested_shadow: &'a [Listed],
    /// Some sphere of `tested_shadow` is an emitter (a shadow ray's target
    /// must then be skipped by id).
    pub shadow_lights: bool,
    /// One light, and no occluder of the lists reaches into it
    /// ([`crate::analysis::Analysis::light_clear`]).
    pub light_clear: bool,
    /// A light can lie entirely below the horizon of a point of a diffuse
    /// plane ([`crate::analysis::Analysis::horizon_planes`]).
    pub horizon_planes: bool,
    /// The same for diffuse spheres.
    pub horizon_spheres: bool,
    /// Windows of the reachable lights that an opaque wall cuts.
    pub windows: &'a [crate::light::Window],
    /// Background radiance.
    pub background: Color,
    /// No ray can escape (the background is never seen).
    pub closed: bool,
    /// The bounding volume hierarchy over `tested`, if the scene has one and
    /// it is used: then every query finds its spheres through it (the same
    /// hits as the lists give).
    pub bvh: Option<BvhView<'a>>,
}

/// Records the hit of the slab plane along one axis (origin and direction
/// components `o`, `d`; the axis' planes `c` and `ids` as in [`Slabs`]) if it
/// is nearer than `t_best`. The ray parameter is bit for bit
/// [`Plane::intersect`]'s. The side is the sign bit of `d`, used as an index
/// (a load, not a branch the processor would have to guess): for `d = ±0`
/// either plane gives t = ±∞, never a hit, as in [`Plane::intersect`].
#[inline(always)]
fn slab_axis(
    o: f32,
    d: f32,
    c: &[f32; 2],
    ids: &[ObjectId; 2],
    t_best: &mut f32,
    best: &mut ObjectId,
) {
    let side = (d.to_bits() >> 31) as usize;
    let (Some(&c), Some(&id)) = (c.get(side), ids.get(side)) else {
        return;
    };
    let t = (c - o) / d;
    // t_best > 0: +∞ or an earlier hit
    if math::positive_below_positive(t, *t_best) {
        *t_best = t;
        *best = id;
    }
}

/// The nearest hit among the `slabs` (if given), `planes` (an index
/// iterator) and `spheres`, skipping the surface the ray leaves. Planes come
/// first, so that spheres beyond the nearest wall are rejected early.
#[inline(always)]
fn nearest<'p>(
    slabs: Option<&Slabs>,
    planes: impl Iterator<Item = (usize, &'p Plane)>,
    spheres: &[Listed],
    tree: Option<(BvhView<'_>, &[Listed])>,
    all_planes: &[Plane],
    ray: &Ray,
    from: ObjectId,
) -> Option<Hit> {
    let mut t_best = f32::INFINITY;
    let mut best = ObjectId::NONE;
    if let Some(sl) = slabs {
        let (o, d) = (ray.origin, ray.dir);
        let [cx, cy, cz] = &sl.c;
        let [ix, iy, iz] = &sl.id;
        slab_axis(o.x, d.x, cx, ix, &mut t_best, &mut best);
        slab_axis(o.y, d.y, cy, iy, &mut t_best, &mut best);
        slab_axis(o.z, d.z, cz, iz, &mut t_best, &mut best);
    }
    for (i, p) in planes {
        let id = ObjectId::plane(i);
        if id == from {
            continue;
        }
        if let Some(t) = p.intersect(ray, t_best) {
            t_best = t;
            best = id;
        }
    }
    // a sphere at exactly the nearest plane's distance wins the tie
    // (spheres take precedence although planes are tested first): accept
    // t ≤ t_best, i.e. t < the next float above it
    let mut t_max = math::next_up_positive(t_best);
    // two copies of the sphere loop: rays that do not leave a sphere (from
    // the camera or a wall) compare no ids
    let hit_sphere = if let Some((tree, list)) = tree {
        // the tree covers every sphere of the list that `spheres` is a
        // prefix of, and gives the hit a loop over it would
        tree.closest(list, ray, &mut t_max, from)
    } else if from.as_sphere().is_some() {
        nearest_sphere::<true>(spheres, ray, &mut t_max, from)
    } else {
        nearest_sphere::<false>(spheres, ray, &mut t_max, from)
    };
    if let Some(l) = hit_sphere {
        Some(l.sphere.hit(ray, t_max, l.id))
    } else {
        // `best` is a plane or none
        all_planes
            .get(best.plane_slot())
            .map(|p| p.hit(ray, t_best, best))
    }
}

/// The nearest of `spheres` that `ray` hits before `t_max` (which becomes
/// its distance); `from` (if `FROM`) is tested from its surface.
#[inline(always)]
fn nearest_sphere<'l, const FROM: bool>(
    spheres: &'l [Listed],
    ray: &Ray,
    t_max: &mut f32,
    from: ObjectId,
) -> Option<&'l Listed> {
    let mut hit = None;
    for l in spheres {
        let t = if FROM && l.id == from {
            l.sphere.intersect_from_surface(ray, *t_max)
        } else {
            l.sphere.intersect(ray, *t_max)
        };
        if let Some(t) = t {
            *t_max = t;
            hit = Some(l);
        }
    }
    hit
}

/// The objects of `all` named by the index list `ids`.
#[inline(always)]
fn listed<'a, T>(ids: &'a [u16], all: &'a [T]) -> impl Iterator<Item = (usize, &'a T)> + 'a {
    ids.iter()
        .filter_map(move |&i| all.get(i as usize).map(|o| (i as usize, o)))
}

impl<'a> SceneView<'a> {
    /// Sphere `i` and its emitted radiance, if it is a light (as the
    /// lists of lights and emitters hold them).
    #[inline(always)]
    pub fn sphere_light(&self, i: u16) -> Option<(&'a Sphere, Color)> {
        let s = self.spheres.get(usize::from(i))?;
        let le = self.materials.get(usize::from(s.material))?.emission()?;
        Some((s, le))
    }

    /// The spheres a camera ray tests: those it can hit when culling by
    /// the view ([`crate::Skip::view_culling`]), else every tested one.
    #[inline(always)]
    pub fn camera_spheres(&self, view_culling: bool) -> &'a [Listed] {
        if view_culling {
            self.tested_primary
        } else {
            self.tested
        }
    }

    /// The tree, if the view has one and this build has its code (a
    /// firmware for a scene below the tree's threshold is built without).
    #[inline(always)]
    fn tree(&self) -> Option<BvhView<'a>> {
        if cfg!(micropt_no_bvh) { None } else { self.bvh }
    }

    /// The closest intersection of `ray` in `(0, ∞)`, for a ray that starts
    /// where a path can be (on the camera's side of every opaque plane: every
    /// ray the integrator traces); the walls are tested as [`Slabs`]. `from`
    /// is the object the ray leaves (or [`ObjectId::NONE`]): a plane is never
    /// hit again by a ray leaving it, and a sphere only on its far side if
    /// the ray enters it.
    #[inline(always)]
    pub fn closest_hit(&self, ray: &Ray, from: ObjectId) -> Option<Hit> {
        self.closest_hit_among(ray, from, self.tested)
    }

    /// [`SceneView::closest_hit`] among the spheres `spheres` only (a
    /// sub-list of [`SceneView::tested`], e.g. [`SceneView::tested_primary`]
    /// for a camera ray). The integrator calls this one query for every ray,
    /// choosing the list, so that its code is inlined once.
    #[inline(always)]
    pub fn closest_hit_among(&self, ray: &Ray, from: ObjectId, spheres: &[Listed]) -> Option<Hit> {
        self.closest_hit_in::<true>(ray, from, spheres)
    }

    /// [`SceneView::closest_hit_among`] compiled with the tree's query
    /// (`TREE`, used when the view has a tree) or without it: the
    /// integrator's loop for a scene without a tree tests nothing about it.
    #[inline(always)]
    pub(crate) fn closest_hit_in<const TREE: bool>(
        &self,
        ray: &Ray,
        from: ObjectId,
        spheres: &[Listed],
    ) -> Option<Hit> {
        // the tree's query is a call of its own, so that the inlined list
        // query stays what it is without a tree
        if TREE && let Some(tree) = self.tree() {
            return self.closest_hit_tree(ray, from, tree);
        }
        nearest(
            self.slabs.as_ref(),
            listed(self.other_planes, self.planes),
            spheres,
            None,
            self.planes,
            ray,
            from,
        )
    }

    /// [`SceneView::closest_hit_among`] through the tree.
    #[inline(never)]
    fn closest_hit_tree(&self, ray: &Ray, from: ObjectId, tree: BvhView<'_>) -> Option<Hit> {
        nearest(
            self.slabs.as_ref(),
            listed(self.other_planes, self.planes),
            &[],
            Some((tree, self.tested)),
            self.planes,
            ray,
            from,
        )
    }

    /// [`SceneView::closest_hit`] for any ray: every plane is tested on its
    /// own (no slabs). Not inlined: the integrator uses it only when
    /// [`crate::Skip::slabs`] is off.
    #[inline(never)]
    pub fn closest_hit_any(&self, ray: &Ray, from: ObjectId) -> Option<Hit> {
        self.closest_hit_any_among(ray, from, self.tested)
    }

    /// [`SceneView::closest_hit_any`] among the spheres `spheres` only.
    ///
    /// Planes at the same ray parameter (in f32, planes far apart tie at a
    /// great distance: two parallel walls a unit apart seen from 1e7 away)
    /// are resolved as [`SceneView::closest_hit_among`] resolves them, so
    /// that the slab skip changes no bit: the slab planes the ray moves
    /// toward first (axes x, y, z), then every other plane in index order.
    #[inline(never)]
    pub fn closest_hit_any_among(
        &self,
        ray: &Ray,
        from: ObjectId,
        spheres: &[Listed],
    ) -> Option<Hit> {
        let mut first = [ObjectId::NONE; 3];
        if let Some(sl) = &self.slabs {
            let d = [ray.dir.x, ray.dir.y, ray.dir.z];
            for ((f, ids), dk) in first.iter_mut().zip(&sl.id).zip(d) {
                if let Some(&id) = ids.get((dk.to_bits() >> 31) as usize) {
                    *f = id;
                }
            }
        }
        let slab_planes = first.into_iter().filter_map(|id| id.as_plane());
        let rest = (0..self.planes.len()).filter(move |&i| !first.contains(&ObjectId::plane(i)));
        nearest(
            None,
            slab_planes
                .chain(rest)
                .filter_map(|i| self.planes.get(i).map(|p| (i, p))),
            spheres,
            self.tree().map(|b| (b, self.tested)),
            self.planes,
            ray,
            from,
        )
    }

    /// Whether anything but the objects `from` (where the ray starts) and
    /// `target` (the light it aims at) blocks `ray` before `t_max`. Only the
    /// objects that the analysis found able to block a shadow ray toward a
    /// reachable light are tested.
    #[inline(always)]
    pub fn occluded(&self, ray: &Ray, t_max: f32, from: ObjectId, target: ObjectId) -> bool {
        self.occluded_in::<true>(ray, t_max, from, target)
    }

    /// [`SceneView::occluded`] compiled with the tree's query (`TREE`) or
    /// without it (see [`SceneView::closest_hit_in`]).
    #[inline(always)]
    pub(crate) fn occluded_in<const TREE: bool>(
        &self,
        ray: &Ray,
        t_max: f32,
        from: ObjectId,
        target: ObjectId,
    ) -> bool {
        if TREE && let Some(tree) = self.tree() {
            return self.occluded_tree(ray, t_max, from, target, tree);
        }
        blocked(
            self.tested_shadow,
            None,
            listed(self.shadow_planes, self.planes),
            ray,
            t_max,
            from,
            target,
            self.shadow_lights,
        )
    }

    /// [`SceneView::occluded`] through the tree.
    #[inline(never)]
    fn occluded_tree(
        &self,
        ray: &Ray,
        t_max: f32,
        from: ObjectId,
        target: ObjectId,
        tree: BvhView<'_>,
    ) -> bool {
        blocked(
            &[],
            Some((tree, self.tested, true)),
            listed(self.shadow_planes, self.planes),
            ray,
            t_max,
            from,
            target,
            true,
        )
    }

    /// [`SceneView::occluded_in`], not inlined: for the integrator's
    /// several-lights variant, where a second inlined copy of the test costs
    /// flash and, on the board, time (docs/bench.md).
    #[inline(never)]
    pub(crate) fn occluded_outlined<const TREE: bool>(
        &self,
        ray: &Ray,
        t_max: f32,
        from: ObjectId,
        target: ObjectId,
    ) -> bool {
        self.occluded_in::<TREE>(ray, t_max, from, target)
    }

    /// [`SceneView::occluded`] testing every object (no analysis). Not
    /// inlined: the integrator uses it only with skips off.
    #[inline(never)]
    pub fn occluded_by_any(&self, ray: &Ray, t_max: f32, from: ObjectId, target: ObjectId) -> bool {
        blocked(
            self.tested,
            self.tree().map(|b| (b, self.tested, false)),
            self.planes.iter().enumerate(),
            ray,
            t_max,
            from,
            target,
            true,
        )
    }
}

/// Whether any of `spheres` and `planes` but `from` and `target` blocks
/// `ray` before `t_max`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn blocked<'p>(
    spheres: &[Listed],
    tree: Option<(BvhView<'_>, &[Listed], bool)>,
    planes: impl Iterator<Item = (usize, &'p Plane)>,
    ray: &Ray,
    t_max: f32,
    from: ObjectId,
    target: ObjectId,
    check_target: bool,
) -> bool {
    if let Some((tree, list, occluders_only)) = tree {
        // the tree over the whole list, skipping what `spheres` leaves out
        if tree.blocked(list, ray, t_max, from, target, occluders_only) {
            return true;
        }
        return planes_block(planes, ray, t_max, from);
    }
    // copies of the sphere loop, so that the common cases (no light in the
    // list; leaving a wall) compare fewer ids
    let hit = match (from.as_sphere().is_some(), check_target) {
        (false, false) => spheres_block::<false, false>(spheres, ray, t_max, from, target),
        (true, false) => spheres_block::<true, false>(spheres, ray, t_max, from, target),
        _ => spheres_block::<true, true>(spheres, ray, t_max, from, target),
    };
    hit || planes_block(planes, ray, t_max, from)
}

/// Whether any of `planes` but `from` blocks `ray` before `t_max`.
#[inline(always)]
fn planes_block<'p>(
    planes: impl Iterator<Item = (usize, &'p Plane)>,
    ray: &Ray,
    t_max: f32,
    from: ObjectId,
) -> bool {
    for (i, p) in planes {
        if ObjectId::plane(i) != from && p.intersect(ray, t_max).is_some() {
            return true;
        }
    }
    false
}

/// Whether a sphere of `spheres` but `target` (if `TARGET`) blocks `ray`
/// before `t_max`; `from` is tested from its surface (if `FROM`: otherwise
/// the ray does not leave a sphere).
#[inline(always)]
fn spheres_block<const FROM: bool, const TARGET: bool>(
    spheres: &[Listed],
    ray: &Ray,
    t_max: f32,
    from: ObjectId,
    target: ObjectId,
) -> bool {
    for l in spheres {
        if TARGET && l.id == target {
            continue;
        }
        let t = if FROM && l.id == from {
            l.sphere.intersect_from_surface(ray, t_max)
        } else {
            l.sphere.intersect(ray, t_max)
        };
        if t.is_some() {
            return true;
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::CameraSpec;
    use crate::geometry::Vec3;
    use crate::material::Material;
    use crate::scene::{Scene, SceneBuilder};

    fn cam() -> CameraSpec {
        CameraSpec::pinhole(
            Vec3::new(0.0, 0.0, 5.0),
            Vec3::ZERO,
            Vec3::new(0.0, 1.0, 0.0),
            45.0,
        )
    }

    #[test]
    fn queries_skip_the_surface_a_ray_leaves() {
        let mut b: SceneBuilder = SceneBuilder::new();
        let m = b.material(Material::Diffuse(Vec3::splat(0.5))).unwrap();
        let s = b.sphere(Vec3::ZERO, 1.0, m).unwrap();
        let p = b
            .plane(Vec3::new(0.0, -1.0, 0.0), Vec3::new(0.0, 1.0, 0.0), m)
            .unwrap();
        b.camera(cam()).unwrap();
        let scene: Scene = b.build().unwrap();
        let v = scene.view(-1.0);
        // from the sphere's top, going up: nothing
        let up = Ray::new(Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 0.0));
        assert!(v.closest_hit(&up, s).is_none());
        // from the sphere's top, going down: far side of the sphere at t = 2
        let down = Ray::new(Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, -1.0, 0.0));
        let h = v.closest_hit(&down, s).unwrap();
        assert_eq!((h.object, h.t), (s, 2.0));
        // from the plane, going down: nothing
        let below = Ray::new(Vec3::new(3.0, -1.0, 0.0), Vec3::new(0.0, -1.0, 0.0));
        assert!(v.closest_hit(&below, p).is_none());
        assert!(!v.occluded(&below, 10.0, p, ObjectId::NONE));
        assert!(v.occluded(&down, 10.0, ObjectId::NONE, ObjectId::NONE));
    }
}
