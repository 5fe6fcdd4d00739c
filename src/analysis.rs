//! Scene analysis at load time: what work a scene can never need.
//!
//! Every rule here is exact geometry about which points a path can reach,
//! with a relative safety margin so that rounding can only make the analysis
//! more conservative:
//!
//! * A path crosses an opaque surface (diffuse, mirror, light) only by
//!   leaving it on the side it came from, so every path vertex lies on the
//!   camera's side of every opaque **plane**, and inside every opaque
//!   **sphere** that contains the camera (outside every other opaque one).
//! * Hence an opaque plane with every reachable light entirely on the camera's
//!   side cannot block a shadow ray (the segment from a vertex to a point of
//!   the light stays in that half-space), and an opaque sphere around the
//!   camera that contains every reachable light entirely cannot either (a ball
//!   is convex). Such objects are left out of shadow-ray tests.
//! * A light entirely behind an opaque plane, outside an opaque sphere around
//!   the camera, or inside an opaque sphere that does not contain the camera
//!   can never be reached: it is not sampled at all.
//! * The camera enclosed by opaque planes (their inward cone of directions is
//!   {0}) or inside an opaque sphere makes the scene **closed**: no ray can
//!   escape, so the background is never looked up (a ray that does escape is
//!   a numerical leak, and is counted).
//! * Spheres entirely outside the cone that bounds the view frustum can never
//!   be hit by a camera ray; they are left out of primary-ray tests.
//! * A scene with one light never selects among lights: it runs an
//!   integrator compiled without light selection.
//! * Since no path vertex lies beyond an opaque plane, a ray can hit an
//!   opaque axis-aligned plane only if it is the nearest such plane on the
//!   camera's side of its axis, in the direction the ray moves along that
//!   axis: per axis and direction one plane is tested (one subtraction and
//!   one division), whatever the number of walls ([`Slabs`]).
//! * With a single reachable light, the light itself never blocks a shadow
//!   ray (shadow rays aim at it): it leaves the occluder list. If moreover
//!   no occluder reaches into the light's ball, a shadow ray may be tested up
//!   to any point of its chord through the light (the chord's midpoint needs
//!   no square root) instead of exactly to the light's surface.
//! * A light lies entirely below the horizon of a diffuse **plane**'s
//!   shading point only if it lies entirely on the plane's far side from the
//!   camera (shading faces the side the path is on, the camera's). With every
//!   light entirely on the camera's side of every diffuse plane, the horizon
//!   test is never done on planes ([`Analysis::horizon_planes`]); likewise on
//!   spheres when every diffuse sphere contains the camera and no light lies
//!   entirely outside it (from inside a ball of radius R, a light of radius
//!   r at distance d from its centre sets below some point's horizon only if
//!   d > R + r: smallpt's walls, balls of radius 1e5 that its lamp pokes
//!   into, never hide it).
//!
//! A camera with a lens starts its rays anywhere on the lens disk: there
//! "the camera" is the ball around the eye that holds the disk, and each
//! rule above asks its question of the whole ball (on one side of a plane,
//! inside or outside a sphere); a plane or sphere that the ball straddles
//! simply decides nothing. A pinhole's ball is its eye.

use crate::camera::CameraSpec;
use crate::geometry::{ObjectId, Plane, Sphere, Vec3};
use crate::light::Window;
use crate::material::Material;
use crate::math;
use heapless::Vec;

/// The fewest spheres for which a bounding volume hierarchy
/// ([`crate::scene::bvh`]) pays: below, a loop over the sphere list costs
/// fewer instructions per ray than the tree's box tests. The crossover is
/// measured per kind of core (random fields, docs/bvh.md): on a host's
/// out-of-order core the tree wins from about 12 spheres, on a
/// microcontroller (in-order, FPU registers only) from about 24. The tree
/// changes no image bit, so the two may differ.
pub const TREE_MIN_SPHERES: usize = if cfg!(target_os = "none") { 24 } else { 12 };

/// Whether a scene of `spheres` listed spheres gets a bounding volume
/// hierarchy.
pub fn tree_pays(spheres: usize) -> bool {
    spheres >= TREE_MIN_SPHERES
}

/// Sorts the view lists together, in place: the larger key first, of equal
/// keys the smaller sphere index (a total order, so the result of any
/// sort). Shell sort (Knuth's gaps): no allocation, no recursion, a few
/// hundred bytes of code, about n^1.5 comparisons at worst (a plain
/// insertion sort took n²/4 on average: most of the load of a scene of
/// thousands of spheres). Core's sort keeps panic branches that the
/// firmware's panic-never link rejects. Without `gaps` it is that insertion
/// sort (gap 1 only): the code a small scene's firmware keeps, as `gaps`
/// is a constant of the scene's capacity.
#[inline(always)]
fn sort_view(keys: &mut [f32], order: &mut [u16], gaps: bool) {
    let n = keys.len().min(order.len());
    let mut gap = 1;
    while gaps && gap < n / 3 {
        gap = 3 * gap + 1;
    }
    while gap > 0 {
        for i in gap..n {
            let mut j = i;
            while j >= gap {
                let (Some([ka, .., kb]), Some([ia, .., ib])) =
                    (keys.get_mut(j - gap..=j), order.get_mut(j - gap..=j))
                else {
                    break;
                };
                if ka.total_cmp(kb).then((*ib).cmp(ia)).is_lt() {
                    core::mem::swap(ka, kb);
                    core::mem::swap(ia, ib);
                    j -= gap;
                } else {
                    break;
                }
            }
        }
        gap /= 3;
    }
}

/// Relative safety margin of the analysis' geometric decisions.
const MARGIN: f32 = 1e-4;

/// What the analysis found (see the module docs).
#[derive(Clone, Debug)]
pub struct Analysis<const S: usize, const P: usize> {
    /// Reachable emitting spheres.
    pub lights: Vec<u16, S>,
    /// All emitting spheres.
    pub emitters: Vec<u16, S>,
    /// Spheres that can block a shadow ray.
    pub shadow_spheres: Vec<u16, S>,
    /// Planes that can block a shadow ray.
    pub shadow_planes: Vec<u16, P>,
    /// Spheres ordered by how far outside the view axis they lie: a camera
    /// ray within a cone of cosine `c` can hit only those whose key is ≥ `c`.
    pub view_order: Vec<u16, S>,
    /// The key of each entry of `view_order` (descending): the cosine of the
    /// smallest angle between the view axis and a direction to the sphere, or
    /// 2 when that angle is 0 (the sphere surrounds or straddles the axis).
    pub view_keys: Vec<f32, S>,
    /// No ray can escape the region of the camera.
    pub closed: bool,
    /// The opaque axis-aligned planes nearest the camera, per axis and side.
    pub slabs: Slabs,
    /// The planes that [`Analysis::slabs`] does not hold (in index order).
    pub other_planes: Vec<u16, P>,
    /// The spheres of `view_order`, in that order, with their ids: what
    /// bounce rays test, and a prefix of which camera rays test (one list,
    /// so that culling changes no tie between equally near spheres).
    pub listed_view: Vec<Listed, S>,
    /// The spheres of `shadow_spheres`, with their ids.
    pub listed_shadow: Vec<Listed, S>,
    /// There is one reachable light and no object of the occluder lists
    /// reaches into its ball: nothing lies between its surface and any point
    /// inside it.
    pub light_clear: bool,
    /// Some emitter can lie entirely below the horizon of a point of a
    /// diffuse plane: the horizon test is worth doing on planes.
    pub horizon_planes: bool,
    /// The same for points of diffuse spheres.
    pub horizon_spheres: bool,
    /// Reachable lights that an opaque wall cuts, with the window through
    /// which the camera's region sees them ([`Window`]).
    pub windows: Vec<Window, S>,
}

impl<const S: usize, const P: usize> Analysis<S, P> {
    /// The analysis of a scene without objects or camera, all zero bits (so
    /// that a `static` holding it goes to `.bss`): what [`analyse_into`]
    /// overwrites. Its `slabs` are zeros, not [`Slabs::EMPTY`]: they are
    /// never used, since a scene without a camera is never rendered.
    pub const EMPTY: Self = Self {
        lights: Vec::new(),
        emitters: Vec::new(),
        shadow_spheres: Vec::new(),
        shadow_planes: Vec::new(),
        view_order: Vec::new(),
        view_keys: Vec::new(),
        closed: false,
        slabs: Slabs::ZERO,
        other_planes: Vec::new(),
        listed_view: Vec::new(),
        listed_shadow: Vec::new(),
        light_clear: false,
        horizon_planes: false,
        horizon_spheres: false,
        windows: Vec::new(),
    };

    /// Back to [`Analysis::EMPTY`], field by field (no temporary of the
    /// whole analysis on the stack).
    #[cfg(feature = "parser")]
    pub(crate) fn clear(&mut self) {
        let Self {
            lights,
            emitters,
            shadow_spheres,
            shadow_planes,
            view_order,
            view_keys,
            closed,
            slabs,
            other_planes,
            listed_view,
            listed_shadow,
            light_clear,
            horizon_planes,
            horizon_spheres,
            windows,
        } = self;
        lights.clear();
        emitters.clear();
        shadow_spheres.clear();
        shadow_planes.clear();
        view_order.clear();
        view_keys.clear();
        *closed = false;
        *slabs = Slabs::ZERO;
        other_planes.clear();
        listed_view.clear();
        listed_shadow.clear();
        *light_clear = false;
        *horizon_planes = false;
        *horizon_spheres = false;
        windows.clear();
    }
}

/// A sphere as the ray queries test it: a copy next to its id, so that a
/// loop over a list reads neither an index nor a second array.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Listed {
    /// The sphere.
    pub sphere: Sphere,
    /// Its id in the scene.
    pub id: ObjectId,
}

/// The spheres named by `ids`, copied with their ids (a push loop:
/// heapless' `collect` keeps a panic branch that the firmware's panic-never
/// link rejects).
/// Out of line: one copy serves both lists.
#[inline(never)]
fn listed<const S: usize>(spheres: &[Sphere], ids: &[u16], out: &mut Vec<Listed, S>) {
    out.clear();
    for &i in ids {
        if let Some(&sphere) = spheres.get(i as usize) {
            // at most as many entries as `ids`, whose capacity is S too
            let _ = out.push(Listed {
                sphere,
                id: ObjectId::sphere(i as usize),
            });
        }
    }
}

/// Per axis, the opaque axis-aligned planes nearest the camera below and
/// above it along that axis. A ray that starts where a path can be moves
/// toward the one above if its direction's component on that axis is
/// positive and toward the one below otherwise, and can hit no other plane
/// of that axis and side first: one test per axis.
///
/// A plane `{x : x_k = c}` is stored by its coordinate `c` (after the sign
/// of its normal is folded in, `(c − o_k) / d_k` is bit for bit the ray
/// parameter that [`Plane::intersect`] computes); a side without such a
/// plane holds ±∞ and [`ObjectId::NONE`]. Both are indexed `[axis][side]`
/// with `side` the sign bit of the direction's component: 0 (moving up) for
/// the plane above, 1 for the one below; a query picks its plane with a
/// load, not a branch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slabs {
    /// Coordinates: `[k][0]` the nearest plane above the camera along axis
    /// `k` (+∞: none), `[k][1]` the nearest below (−∞: none).
    pub c: [[f32; 2]; 3],
    /// The planes of `c`.
    pub id: [[ObjectId; 2]; 3],
}

impl Slabs {
    /// No planes.
    pub const EMPTY: Self = Self {
        c: [[f32::INFINITY, f32::NEG_INFINITY]; 3],
        id: [[ObjectId::NONE; 2]; 3],
    };

    /// All zero bits: [`Analysis::EMPTY`]'s (never used).
    const ZERO: Self = Self {
        c: [[0.0; 2]; 3],
        id: [[ObjectId::sphere(0); 2]; 3],
    };
}

/// The axis and the signed coordinate of a plane whose normal is exactly a
/// coordinate axis (±1 there, 0 elsewhere): `(k, c)` with the plane
/// `{x : x_k = c}` and `c = n_k · offset`.
fn axis_plane(p: &Plane) -> Option<(usize, f32)> {
    let n = [p.normal.x, p.normal.y, p.normal.z];
    let mut found = None;
    for (k, &v) in n.iter().enumerate() {
        if v == 1.0 || v == -1.0 {
            if found.is_some() {
                return None;
            }
            found = Some((k, v * p.offset));
        } else if v != 0.0 {
            return None;
        }
    }
    found
}

/// [`Slabs`] of the opaque axis-aligned planes that do not pass within
/// `reach` of the eye (through the lens), and the list of every other plane.
/// A lens position's coordinate `e_k + o_k` with `|o_k| ≤ reach` rounds to at
/// most the rounded `e_k + reach` (rounding is monotonic), so a plane beyond
/// that bound has every camera ray's origin strictly on the eye's side.
fn slabs<const P: usize>(
    planes: &[Plane],
    materials: &[Material],
    eye: Vec3,
    reach: f32,
    other: &mut Vec<u16, P>,
) -> Slabs {
    let mut sl = Slabs::EMPTY;
    let e = [eye.x, eye.y, eye.z];
    // the chosen plane of [axis][side], side 0 above the eye, 1 below
    let mut chosen: [[Option<usize>; 2]; 3] = [[None; 2]; 3];
    for (i, p) in planes.iter().enumerate() {
        let Some((k, c)) = axis_plane(p) else {
            continue;
        };
        if !is_opaque(materials, p.material) {
            continue;
        }
        let (Some(&ek), Some(cs), Some(ch)) = (e.get(k), sl.c.get_mut(k), chosen.get_mut(k)) else {
            continue;
        };
        let [hi, lo] = cs;
        let [ch_hi, ch_lo] = ch;
        if c > ek + reach && c < *hi {
            *hi = c;
            *ch_hi = Some(i);
        } else if c < ek - reach && c > *lo {
            *lo = c;
            *ch_lo = Some(i);
        }
    }
    for (ids, ch) in sl.id.iter_mut().zip(&chosen) {
        for (id, c) in ids.iter_mut().zip(ch) {
            if let Some(i) = c {
                *id = ObjectId::plane(*i);
            }
        }
    }
    other.clear();
    for i in 0..planes.len() {
        if !chosen.iter().flatten().any(|&c| c == Some(i)) {
            let _ = other.push(i as u16);
        }
    }
    sl
}

fn is_opaque(materials: &[Material], m: u16) -> bool {
    materials
        .get(m as usize)
        .is_some_and(|x| !x.is_transparent())
}

/// Signed distance of `p` from a plane, and a bound on its rounding error.
fn plane_distance(pl: &Plane, p: Vec3) -> (f32, f32) {
    let d = pl.normal.dot(p) - pl.offset;
    let scale = pl.normal.abs().dot(p.abs()) + math::abs(pl.offset);
    (d, MARGIN * scale)
}

// The tests below and `Setting`'s are out of line (`#[inline(never)]`):
// the analysis runs once per scene load, and one copy of each test serves
// every analysis that asks it. Inlined at each use they cost cornell's
// Cortex-M4F firmware 640 bytes of flash.

/// `inner` lies strictly inside ball `outer`.
#[inline(never)]
fn sphere_inside(inner: &Sphere, outer: &Sphere) -> bool {
    let d = (inner.center - outer.center).length();
    let tol = MARGIN * (d + inner.radius + outer.radius + outer.center.abs().max_component());
    d + inner.radius < outer.radius - tol
}

/// `inner` lies strictly outside ball `outer`.
#[inline(never)]
fn sphere_outside(inner: &Sphere, outer: &Sphere) -> bool {
    let d = (inner.center - outer.center).length();
    let tol = MARGIN * (d + inner.radius + outer.radius + outer.center.abs().max_component());
    d - inner.radius > outer.radius + tol
}

/// Every point within `reach` of `p` strictly inside ball `s` (`reach` 0:
/// the point itself).
#[inline(never)]
fn point_inside(p: Vec3, reach: f32, s: &Sphere) -> bool {
    let d = (p - s.center).length();
    d + reach < s.radius * (1.0 - MARGIN) - MARGIN * s.center.abs().max_component()
}

/// Every point within `reach` of `p` strictly outside ball `s`.
#[inline(never)]
fn point_outside(p: Vec3, reach: f32, s: &Sphere) -> bool {
    let d = (p - s.center).length();
    d - reach > s.radius * (1.0 + MARGIN) + MARGIN * s.center.abs().max_component()
}

/// Analyses a scene's arrays (see the module docs) into `out`, every field
/// rewritten, in place: the analysis is never on the stack (the firmware
/// builds its scene in static memory this way). One function per analysis,
/// each proving one skip, in the order their results feed each other.
pub fn analyse_into<const S: usize, const P: usize>(
    out: &mut Analysis<S, P>,
    spheres: &[Sphere],
    planes: &[Plane],
    materials: &[Material],
    camera: &CameraSpec,
) {
    let at = Setting {
        spheres,
        planes,
        materials,
        eye: camera.eye,
        // Where camera rays start: within `reach` of the eye (0 for a
        // pinhole; the lens disk's radius with a margin for the rounding of
        // a lens position). Every decision about the camera's position holds
        // for that whole ball, so a lens is "the camera" as the module docs
        // say.
        reach: camera.aperture * (1.0 + MARGIN),
    };
    reachable_lights(&at, &mut out.lights, &mut out.emitters);
    shadow_occluders(
        &at,
        &out.lights,
        &mut out.shadow_planes,
        &mut out.shadow_spheres,
    );
    out.closed = closed(&at);
    view_order(&at, camera, &mut out.view_order, &mut out.view_keys);
    out.light_clear = light_clear(&at, &out.lights, &out.shadow_spheres, &out.shadow_planes);
    windows(&at, &out.lights, &mut out.windows);
    out.horizon_planes = horizon_planes(&at, &out.emitters);
    out.horizon_spheres = horizon_spheres(&at, &out.emitters);
    out.slabs = slabs(planes, materials, at.eye, at.reach, &mut out.other_planes);
    listed(spheres, &out.view_order, &mut out.listed_view);
    listed(spheres, &out.shadow_spheres, &mut out.listed_shadow);
}

/// A scene's arrays and the ball camera rays start from, as every analysis
/// asks them.
struct Setting<'s> {
    spheres: &'s [Sphere],
    planes: &'s [Plane],
    materials: &'s [Material],
    /// The eye.
    eye: Vec3,
    /// The radius of the ball around the eye that holds every camera ray's
    /// origin.
    reach: f32,
}

impl Setting<'_> {
    /// Which side of plane `pl` the camera is on: ±1, or 0 where it is on
    /// the plane or the lens reaches across it.
    #[inline(never)]
    fn side(&self, pl: &Plane) -> f32 {
        let (d, tol) = plane_distance(pl, self.eye);
        if d > tol + self.reach {
            1.0
        } else if d < -tol - self.reach {
            -1.0
        } else {
            0.0
        }
    }

    /// All of light `l` lies on the camera's side of plane `pl`.
    #[inline(never)]
    fn light_on_camera_side(&self, pl: &Plane, l: &Sphere) -> bool {
        let (d, tol) = plane_distance(pl, l.center);
        let s = self.side(pl);
        s != 0.0 && d * s > l.radius * (1.0 + MARGIN) + tol
    }

    /// All of light `l` lies on the far side of plane `pl` from the camera.
    #[inline(never)]
    fn light_behind(&self, pl: &Plane, l: &Sphere) -> bool {
        let (d, tol) = plane_distance(pl, l.center);
        let s = self.side(pl);
        s != 0.0 && -d * s > l.radius * (1.0 + MARGIN) + tol
    }

    /// The whole camera ball lies strictly inside ball `q`.
    #[inline(never)]
    fn camera_inside(&self, q: &Sphere) -> bool {
        point_inside(self.eye, self.reach, q)
    }

    fn opaque_planes(&self) -> impl Iterator<Item = &Plane> {
        self.planes
            .iter()
            .filter(|p| is_opaque(self.materials, p.material))
    }

    fn opaque_spheres(&self) -> impl Iterator<Item = &Sphere> {
        self.spheres
            .iter()
            .filter(|s| is_opaque(self.materials, s.material))
    }

    /// The spheres that `ids` name.
    fn spheres_of<'i>(&self, ids: &'i [u16]) -> impl Iterator<Item = &Sphere> + 'i
    where
        Self: 'i,
    {
        let spheres = self.spheres;
        ids.iter().filter_map(move |&i| spheres.get(i as usize))
    }
}

/// The emitting spheres, and those of them a path can reach (the
/// `unreachable_lights` skip): a light entirely behind an opaque plane,
/// outside an opaque sphere around the camera, or inside an opaque sphere
/// that does not hold the camera, is never sampled.
fn reachable_lights<const S: usize>(
    at: &Setting,
    lights: &mut Vec<u16, S>,
    emitters: &mut Vec<u16, S>,
) {
    lights.clear();
    emitters.clear();
    for (i, l) in at.spheres.iter().enumerate() {
        let emits = at
            .materials
            .get(l.material as usize)
            .and_then(Material::emission)
            .is_some_and(|le| le.max_component() > 0.0);
        if !emits {
            continue;
        }
        let _ = emitters.push(i as u16);
        let hidden_by_plane = at.opaque_planes().any(|p| at.light_behind(p, l));
        let hidden_by_sphere = at.opaque_spheres().any(|q| {
            !core::ptr::eq(q, l)
                && ((at.camera_inside(q) && sphere_outside(l, q))
                    || (point_outside(at.eye, at.reach, q) && sphere_inside(l, q)))
        });
        if !hidden_by_plane && !hidden_by_sphere {
            let _ = lights.push(i as u16);
        }
    }
}

/// The objects a shadow ray toward a reachable light must test (the
/// `shadow_occluders` skip): not an opaque plane with every reachable light
/// on the camera's side, not an opaque sphere around the camera that holds
/// every reachable light, not the one light itself.
fn shadow_occluders<const S: usize, const P: usize>(
    at: &Setting,
    lights: &[u16],
    shadow_planes: &mut Vec<u16, P>,
    shadow_spheres: &mut Vec<u16, S>,
) {
    shadow_planes.clear();
    shadow_spheres.clear();
    for (i, p) in at.planes.iter().enumerate() {
        let skip = is_opaque(at.materials, p.material)
            && at.spheres_of(lights).all(|l| at.light_on_camera_side(p, l));
        if !skip {
            let _ = shadow_planes.push(i as u16);
        }
    }
    for (i, q) in at.spheres.iter().enumerate() {
        let the_only_light = lights.len() == 1 && lights.first() == Some(&(i as u16));
        let skip = the_only_light
            || is_opaque(at.materials, q.material)
                && at.camera_inside(q)
                && at
                    .spheres_of(lights)
                    .all(|l| !core::ptr::eq(l, q) && sphere_inside(l, q));
        if !skip {
            let _ = shadow_spheres.push(i as u16);
        }
    }
}

/// Whether no ray can escape the camera's region (the `closed` skip): the
/// camera inside an opaque sphere, or enclosed by opaque planes.
fn closed(at: &Setting) -> bool {
    at.opaque_spheres().any(|q| at.camera_inside(q)) || planes_enclose(at)
}

/// The view culling keys (the `view_culling` skip), sorted with the spheres'
/// indices by descending key: the cosine of the smallest angle between the
/// view axis and a direction to the sphere, 2 where the axis passes through
/// the sphere's cone. Every point of a lens ray lies within the lens radius
/// of the ray from the eye in the same direction, so each sphere is grown
/// by `reach` (`Camera::view_cos` widens the cone to match).
fn view_order<const S: usize>(
    at: &Setting,
    camera: &CameraSpec,
    view_order: &mut Vec<u16, S>,
    view_keys: &mut Vec<f32, S>,
) {
    view_order.clear();
    view_keys.clear();
    let axis = (camera.target - at.eye).normalize();
    for (i, s) in at.spheres.iter().enumerate() {
        let to_c = s.center - at.eye;
        let d = to_c.length();
        let radius = s.radius + at.reach;
        let key = if !(d > radius * (1.0 + MARGIN)) {
            2.0
        } else {
            let cos_t = to_c.dot(axis) / d;
            let sin_t = to_c.cross(axis).length() / d;
            let sin_a = math::min(radius / d * (1.0 + MARGIN), 1.0);
            let cos_a = math::safe_sqrt(1.0 - sin_a * sin_a);
            // angle to the centre minus the angular radius, as a cosine
            if sin_t * cos_a <= sin_a * cos_t && cos_t > 0.0 || sin_a >= 1.0 {
                2.0 // the axis passes through the sphere's cone
            } else {
                cos_t * cos_a + sin_t * sin_a
            }
        };
        // at most S spheres, the capacity of both
        let _ = view_keys.push(key);
        let _ = view_order.push(i as u16);
    }
    // the two lists sorted together by descending key, then index (a total
    // order, so the same result as any sort), in place: no list of the
    // spheres on the stack, and far below n² for scenes of thousands; gaps
    // only where there can be many spheres
    sort_view(view_keys.as_mut_slice(), view_order.as_mut_slice(), S > 64);
}

/// Whether nothing of the occluder lists reaches into the one reachable
/// light's ball (the chord test of shadow rays): a shadow ray may then end
/// at any point of its chord through the light.
fn light_clear(
    at: &Setting,
    lights: &[u16],
    shadow_spheres: &[u16],
    shadow_planes: &[u16],
) -> bool {
    let ([_], Some(l)) = (lights, at.spheres_of(lights).next()) else {
        return false;
    };
    at.spheres_of(shadow_spheres).all(|q| sphere_outside(q, l))
        && shadow_planes
            .iter()
            .filter_map(|&i| at.planes.get(i as usize))
            .all(|p| {
                let (d, tol) = plane_distance(p, l.center);
                math::abs(d) > l.radius * (1.0 + MARGIN) + tol
            })
}

/// The windows of reachable lights (the `windows` skip): the opaque wall
/// that leaves the smallest cap of each light on the camera's side. A plane
/// with the light's centre behind it; a ball around the camera with the
/// light's centre outside it, cut along their radical plane (a ball's part
/// inside another ball is its part on one side of that plane), at
/// s0 = (pow(c) + r²) / (2d) from the light's centre, pow(c) = |c − o|² − R²
/// computed to a few ulps. Each distance is reduced by its rounding margin:
/// a disk nearer the centre is wider and still shows all of the cap.
fn windows<const S: usize>(at: &Setting, lights: &[u16], windows: &mut Vec<Window, S>) {
    windows.clear();
    if !cfg!(feature = "windows") {
        return;
    }
    for &i in lights {
        let Some(l) = at.spheres.get(i as usize) else {
            continue;
        };
        let mut best: Option<(f32, Vec3)> = None;
        let mut consider = |s0: f32, toward: Vec3| {
            if s0 > 0.0 && s0 < l.radius && best.is_none_or(|(b, _)| s0 > b) {
                best = Some((s0, toward));
            }
        };
        for p in at.opaque_planes() {
            let (d, tol) = plane_distance(p, l.center);
            let s = at.side(p);
            if s != 0.0 && -d * s > tol {
                consider(-d * s - tol, p.normal * s);
            }
        }
        for q in at.opaque_spheres() {
            if core::ptr::eq(q, l) || !at.camera_inside(q) {
                continue;
            }
            let to_q = q.center - l.center;
            let d = to_q.length();
            if !(d > 0.0) {
                continue;
            }
            let pow = q.origin_power(l.center);
            let s0 = (pow + l.radius2) / (2.0 * d);
            // pow to a few ulps, d and the sum to one each, the light's own
            // centre rounded at its scale: all within 16 roundings of these
            let scale = math::abs(pow) / (2.0 * d) + l.radius + l.center.abs().max_component();
            let tol = math::gamma(16) * scale;
            consider(s0 - tol, to_q * (1.0 / d));
        }
        if let Some((s0, toward)) = best
            && let Some(w) = Window::new(i, l.center, l.radius, toward, s0)
        {
            let _ = windows.push(w);
        }
    }
}

/// Whether a material samples lights (its points do the horizon test).
fn is_diffuse(materials: &[Material], m: u16) -> bool {
    materials
        .get(m as usize)
        .is_some_and(Material::samples_lights)
}

/// Whether some emitter can lie entirely below the horizon of a point of a
/// diffuse plane (the `horizon` skip, on planes): only one not entirely on
/// the camera's side of the plane, as shading faces the camera's side.
/// Emitters, a superset of the reachable lights, so that the answer holds
/// with the unreachable-lights skip off too.
fn horizon_planes(at: &Setting, emitters: &[u16]) -> bool {
    at.planes
        .iter()
        .filter(|p| is_diffuse(at.materials, p.material))
        .any(|p| {
            at.spheres_of(emitters)
                .any(|l| !at.light_on_camera_side(p, l))
        })
}

/// The same for points of diffuse spheres (the `horizon` skip, on
/// spheres). From inside ball q (inward normal n at p = o + R·u is −u) a
/// light of centre c and radius r sets below p's horizon where
/// n·(c − p) = R − u·(c − o) < −r: for some p iff |c − o| > R + r, i.e.
/// only a light entirely outside the ball. (A wrong answer here costs time,
/// never correctness: a light below the horizon contributes zero either
/// way, so the tolerances are rounding ones, not MARGIN: smallpt's camera
/// is 2 units inside a ball of radius 1e5.)
fn horizon_spheres(at: &Setting, emitters: &[u16]) -> bool {
    let sets_inside = |q: &Sphere, l: &Sphere| {
        let d = (l.center - q.center).length();
        d > (q.radius + l.radius) * (1.0 - 1e-6)
    };
    let eye_inside = |q: &Sphere| (at.eye - q.center).length() + at.reach < q.radius * (1.0 - 1e-6);
    at.spheres
        .iter()
        .filter(|q| is_diffuse(at.materials, q.material))
        .any(|q| {
            !(eye_inside(q)
                && at
                    .spheres_of(emitters)
                    .all(|l| !core::ptr::eq(q, l) && !sets_inside(q, l)))
        })
}

/// Whether the opaque planes enclose `eye`: the cone of directions `v` with
/// `n_i · v ≥ 0` for every plane's normal turned toward the eye is {0}. If
/// it is not, it contains `±(n_i × n_j)` for some pair (its extreme rays or
/// lineality space), or all normals are parallel.
fn planes_enclose(at: &Setting) -> bool {
    let mut normals: Vec<Vec3, 32> = Vec::new();
    for p in at.opaque_planes() {
        let s = at.side(p);
        if s != 0.0 && normals.push(p.normal * s).is_err() {
            return false;
        }
    }
    let feasible = |v: Vec3| normals.iter().all(|n| n.dot(v) >= -1e-6);
    let mut any_pair = false;
    for (i, a) in normals.iter().enumerate() {
        for b in normals.iter().skip(i + 1) {
            let c = a.cross(*b);
            if c.length_squared() > 1e-12 {
                any_pair = true;
                let c = c.normalize();
                if feasible(c) || feasible(-c) {
                    return false;
                }
            }
        }
    }
    any_pair
}

#[cfg(test)]
mod tests {
    use super::sort_view;

    /// The view lists' shell sort gives the order of a plain insertion sort
    /// by the same total order (larger key first, then smaller index; keys
    /// with many ties, both signs, ±0 and the "on the axis" key 2), for
    /// lengths 0 to 200.
    #[test]
    fn the_view_sort_is_the_insertion_sort_order() {
        let mut state = 0x9e37_79b9_u32;
        for n in 0..200usize {
            let mut keys = [0.0f32; 200];
            let mut order = [0u16; 200];
            for (i, (k, o)) in keys.iter_mut().zip(order.iter_mut()).enumerate().take(n) {
                state ^= state << 13;
                state ^= state >> 17;
                state ^= state << 5;
                *k = match state % 7 {
                    0 => 2.0,
                    1 => -0.0,
                    2 => 0.0,
                    r => (state >> 8) as f32 / 16_777_216.0 * if r % 2 == 0 { 1.0 } else { -1.0 },
                };
                if state.is_multiple_of(5) {
                    *k = 0.25;
                }
                *o = i as u16;
            }
            let (mut k2, mut o2) = (keys, order);
            sort_view(&mut keys[..n], &mut order[..n], true);
            let before = |k: &[f32], o: &[u16], a: usize, b: usize| {
                k[b].total_cmp(&k[a]).then(o[a].cmp(&o[b])).is_lt()
            };
            for i in 1..n {
                let mut j = i;
                while j > 0 && before(&k2, &o2, j, j - 1) {
                    k2.swap(j, j - 1);
                    o2.swap(j, j - 1);
                    j -= 1;
                }
            }
            assert_eq!(order[..n], o2[..n], "n = {n}");
            for (a, b) in keys[..n].iter().zip(&k2[..n]) {
                assert_eq!(a.to_bits(), b.to_bits(), "n = {n}");
            }
        }
    }
}
