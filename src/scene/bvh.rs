//! A bounding volume hierarchy over a scene's spheres: how a ray skips the
//! spheres it cannot hit when there are many.
//!
//! The tree indexes the analysis' list of spheres ([`Listed`], in view
//! order); a leaf names positions in that list. It is built at scene load
//! without a heap (binned surface-area heuristic, storage sized by the
//! scene's sphere capacity) and is a pure function of the list, so host and
//! board build the same tree.
//!
//! * Every leaf holds at least two spheres (unless the scene has one), so a
//!   tree over `n` spheres has at most `n − 1` nodes: `S` of them fit.
//! * The closest-hit query returns exactly what a loop over the list in
//!   order returns: the smallest ray parameter, and of equal ones the sphere
//!   first in the list (the loop accepts only a strictly nearer hit). The
//!   order in which the tree visits spheres changes nothing.
//! * A sphere's box is its bounding cube widened by a relative margin, and
//!   the box test accepts a slightly longer ray interval than asked: the
//!   rounding of the box test and of [`Sphere::intersect`] can only make the
//!   tree test a sphere more, never skip one the loop would hit.
//!
//! [`Sphere::intersect`]: crate::geometry::Sphere::intersect

use crate::analysis::Listed;
use crate::geometry::{ObjectId, Ray, Vec3};
use crate::math;
use heapless::Vec;

/// Relative widening of a sphere's box (of its radius plus its centre's
/// largest coordinate): far above the rounding of the box test and of the
/// sphere test (a few f32 ulps of those magnitudes).
const PAD: f32 = 1.0 / 16_384.0;
/// Relative lengthening of the ray interval a box test accepts.
const SLACK: f32 = 1.0 + 1.0 / 16_384.0;
/// Bins of the split search.
const BINS: usize = 12;
/// Item flag: the sphere cannot block a shadow ray toward a reachable light
/// (not in the analysis' occluder list).
const NOT_SHADOW: u16 = 0x8000;
/// Nodes deeper than this are split at the middle of their range, whatever
/// the heuristic says, so that the tree's depth stays below [`STACK`].
const SAH_DEPTH: u16 = 40;
/// Traversal stack entries: more than the depth of any tree built here
/// ([`SAH_DEPTH`] plus halvings of at most 2¹⁵ spheres).
const STACK: usize = 64;
/// Ranges waiting to be built: the builder continues with the smaller half
/// of each split, so at most log₂ n ranges wait.
const PENDING: usize = 32;

/// A node of the tree: its box and either its children or its spheres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Node {
    /// Lower corner of the box.
    pub lo: [f32; 3],
    /// Upper corner of the box.
    pub hi: [f32; 3],
    /// An inner node: the index of its second child (the first is the next
    /// node). A leaf: the index of its first item.
    pub index: u16,
    /// A leaf: its number of items (≥ 1). An inner node: 0.
    pub count: u16,
}

/// The tree over a scene's listed spheres (see the module docs), with room
/// for `S` spheres.
#[derive(Clone, Debug)]
pub struct Bvh<const S: usize> {
    nodes: Vec<Node, S>,
    /// Positions in the sphere list (with [`NOT_SHADOW`]), leaf by leaf.
    items: Vec<u16, S>,
    depth: u16,
}

/// A borrowed [`Bvh`], independent of its capacity: what the queries use.
#[derive(Clone, Copy, Debug)]
pub struct BvhView<'a> {
    nodes: &'a [Node],
    items: &'a [u16],
}

/// The box of a sphere, widened by [`PAD`].
fn sphere_box(l: &Listed) -> ([f32; 3], [f32; 3]) {
    let c = l.sphere.center;
    let big = math::max(math::max(math::abs(c.x), math::abs(c.y)), math::abs(c.z));
    let r = l.sphere.radius + (l.sphere.radius + big) * PAD;
    ([c.x - r, c.y - r, c.z - r], [c.x + r, c.y + r, c.z + r])
}

/// An empty box (the identity of [`grow`]).
const EMPTY_BOX: ([f32; 3], [f32; 3]) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);

/// `b` grown to contain the box `lo..hi`.
fn grow(b: &mut ([f32; 3], [f32; 3]), lo: &[f32; 3], hi: &[f32; 3]) {
    for k in 0..3 {
        if let (Some(bl), Some(bh), Some(&l), Some(&h)) =
            (b.0.get_mut(k), b.1.get_mut(k), lo.get(k), hi.get(k))
        {
            *bl = math::min(*bl, l);
            *bh = math::max(*bh, h);
        }
    }
}

/// Half the surface area of a box (0 for an empty one).
fn half_area(b: &([f32; 3], [f32; 3])) -> f32 {
    let ([lx, ly, lz], [hx, hy, hz]) = *b;
    let (dx, dy, dz) = (hx - lx, hy - ly, hz - lz);
    if !(dx >= 0.0) {
        return 0.0;
    }
    dx * dy + dy * dz + dz * dx
}

/// The coordinate `k` of a vector.
fn coord(v: Vec3, k: usize) -> f32 {
    match k {
        0 => v.x,
        1 => v.y,
        _ => v.z,
    }
}

impl<const S: usize> Default for Bvh<S> {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl<const S: usize> Bvh<S> {
    /// No tree (all zero bits).
    pub const EMPTY: Self = Self {
        nodes: Vec::new(),
        items: Vec::new(),
        depth: 0,
    };

    /// Drops the tree.
    pub fn clear(&mut self) {
        self.nodes.clear();
        self.items.clear();
        self.depth = 0;
    }

    /// Number of nodes (0: no tree).
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Whether there is no tree.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Number of nodes on the longest path from the root to a leaf.
    pub fn depth(&self) -> u16 {
        self.depth
    }

    /// The tree borrowed, or `None` if there is none.
    pub fn view(&self) -> Option<BvhView<'_>> {
        // a firmware built without the tree's code has none
        (!cfg!(micropt_no_bvh) && !self.nodes.is_empty()).then_some(BvhView {
            nodes: &self.nodes,
            items: &self.items,
        })
    }

    /// Builds the tree over `spheres` (replacing any previous one); the
    /// spheres whose index is not in `shadow` (ascending scene indices: the
    /// analysis' occluder list) are marked as never blocking a shadow ray.
    /// No tree is built for an empty list or one of more than 2¹⁵ − 1
    /// spheres.
    pub fn build(&mut self, spheres: &[Listed], shadow: &[u16]) {
        self.clear();
        let n = spheres.len();
        if n == 0 || n >= NOT_SHADOW as usize || n > S {
            return;
        }
        for (p, l) in spheres.iter().enumerate() {
            let occluder =
                l.id.as_sphere()
                    .is_some_and(|i| shadow.binary_search(&(i as u16)).is_ok());
            let flag = if occluder { 0 } else { NOT_SHADOW };
            // n ≤ S items
            let _ = self.items.push(p as u16 | flag);
        }
        // (start, end, parent node or u16::MAX, depth)
        let mut pending: Vec<(u16, u16, u16, u16), PENDING> = Vec::new();
        let mut range = (0u16, n as u16, u16::MAX, 1u16);
        loop {
            let (start, end, parent, depth) = range;
            let me = self.nodes.len() as u16;
            if let Some(p) = self.nodes.get_mut(parent as usize) {
                p.index = me;
            }
            self.depth = self.depth.max(depth);
            let split = self.make_node(spheres, start, end, depth, pending.is_full());
            match split {
                Some(mid) => {
                    // continue with the smaller half as the first child
                    let (small, large) = if mid - start <= end - mid {
                        ((start, mid), (mid, end))
                    } else {
                        ((mid, end), (start, mid))
                    };
                    let _ = pending.push((large.0, large.1, me, depth + 1));
                    range = (small.0, small.1, u16::MAX, depth + 1);
                }
                None => match pending.pop() {
                    Some(r) => range = r,
                    None => break,
                },
            }
        }
    }

    /// Appends the node of items `start..end`, and partitions them if it is
    /// an inner node: returns where its second half starts (`None`: a leaf).
    fn make_node(
        &mut self,
        spheres: &[Listed],
        start: u16,
        end: u16,
        depth: u16,
        leaf_only: bool,
    ) -> Option<u16> {
        let (s, e) = (start as usize, end as usize);
        let sphere_at = |item: u16| spheres.get((item & !NOT_SHADOW) as usize);
        let mut bounds = EMPTY_BOX;
        let mut centres = EMPTY_BOX;
        for &it in self.items.get(s..e).unwrap_or(&[]) {
            if let Some(l) = sphere_at(it) {
                let (lo, hi) = sphere_box(l);
                grow(&mut bounds, &lo, &hi);
                let c = [l.sphere.center.x, l.sphere.center.y, l.sphere.center.z];
                grow(&mut centres, &c, &c);
            }
        }
        let count = end - start;
        let leaf = count <= 3 || leaf_only;
        // the nodes never outnumber the spheres (leaves of ≥ 2)
        let _ = self.nodes.push(Node {
            lo: bounds.0,
            hi: bounds.1,
            index: start,
            count: if leaf { count } else { 0 },
        });
        if leaf {
            return None;
        }
        // the widest axis of the centres
        let ([lx, ly, lz], [hx, hy, hz]) = centres;
        let (ex, ey, ez) = (hx - lx, hy - ly, hz - lz);
        let (k, cmin, width) = if ex >= ey && ex >= ez {
            (0, lx, ex)
        } else if ey >= ez {
            (1, ly, ey)
        } else {
            (2, lz, ez)
        };
        let middle = start + count / 2;
        if depth >= SAH_DEPTH || !(width > 0.0) {
            return Some(middle);
        }
        let scale = BINS as f32 * (1.0 - 1.0 / 1024.0) / width;
        let bin = |l: &Listed| {
            let b = ((coord(l.sphere.center, k) - cmin) * scale) as usize;
            b.min(BINS - 1)
        };
        let mut boxes = [EMPTY_BOX; BINS];
        let mut counts = [0u16; BINS];
        for &it in self.items.get(s..e).unwrap_or(&[]) {
            if let Some(l) = sphere_at(it) {
                let b = bin(l);
                let (lo, hi) = sphere_box(l);
                if let (Some(bx), Some(c)) = (boxes.get_mut(b), counts.get_mut(b)) {
                    grow(bx, &lo, &hi);
                    *c += 1;
                }
            }
        }
        // sweep from the right: the area × count of bins j.. for every j
        let mut right_cost = [0.0f32; BINS];
        let (mut acc, mut cnt) = (EMPTY_BOX, 0u16);
        for j in (1..BINS).rev() {
            if let (Some(bx), Some(&c)) = (boxes.get(j), counts.get(j)) {
                grow(&mut acc, &bx.0, &bx.1);
                cnt += c;
            }
            if let Some(rc) = right_cost.get_mut(j) {
                *rc = if cnt >= 2 {
                    half_area(&acc) * cnt as f32
                } else {
                    f32::INFINITY
                };
            }
        }
        let (mut acc, mut cnt) = (EMPTY_BOX, 0u16);
        let (mut best, mut best_cost) = (0usize, f32::INFINITY);
        for j in 1..BINS {
            if let (Some(bx), Some(&c)) = (boxes.get(j - 1), counts.get(j - 1)) {
                grow(&mut acc, &bx.0, &bx.1);
                cnt += c;
            }
            let rc = right_cost.get(j).copied().unwrap_or(f32::INFINITY);
            if cnt >= 2 {
                let cost = half_area(&acc) * cnt as f32 + rc;
                if cost < best_cost {
                    best_cost = cost;
                    best = j;
                }
            }
        }
        if best == 0 {
            return Some(middle);
        }
        // partition: the items of bins < best first (in place, in order
        // of the scan: deterministic)
        let mut i = s;
        for j in s..e {
            let goes_left = self
                .items
                .get(j)
                .and_then(|&it| sphere_at(it))
                .is_some_and(|l| bin(l) < best);
            if goes_left {
                if let Some([first, .., last]) = self.items.get_mut(i..=j) {
                    core::mem::swap(first, last);
                }
                i += 1;
            }
        }
        Some(i as u16)
    }
}

/// A ray prepared for box tests: origin and reciprocal direction.
#[derive(Clone, Copy)]
struct BoxRay {
    o: [f32; 3],
    inv: [f32; 3],
}

impl BoxRay {
    fn new(ray: &Ray) -> Self {
        let (o, d) = (ray.origin, ray.dir);
        Self {
            o: [o.x, o.y, o.z],
            inv: [1.0 / d.x, 1.0 / d.y, 1.0 / d.z],
        }
    }

    /// The ray parameter where the ray enters `node`'s box, if it meets the
    /// box within `[0, t_max]` (lengthened by [`SLACK`]). A NaN slab bound
    /// (the origin on a slab plane of an axis the ray does not move along)
    /// leaves the interval unchanged.
    #[inline(always)]
    fn enter(&self, node: &Node, t_max: f32) -> Option<f32> {
        let [ox, oy, oz] = self.o;
        let [ix, iy, iz] = self.inv;
        let [lx, ly, lz] = node.lo;
        let [hx, hy, hz] = node.hi;
        let (mut t0, mut t1) = (0.0f32, t_max);
        slab(lx, hx, ox, ix, &mut t0, &mut t1);
        slab(ly, hy, oy, iy, &mut t0, &mut t1);
        slab(lz, hz, oz, iz, &mut t0, &mut t1);
        if t0 <= t1 * SLACK { Some(t0) } else { None }
    }
}

/// Narrows the ray interval `t0..t1` to the slab `lo..hi` of one axis
/// (origin `o`, reciprocal direction `inv`); a NaN bound changes nothing.
#[inline(always)]
fn slab(lo: f32, hi: f32, o: f32, inv: f32, t0: &mut f32, t1: &mut f32) {
    let a = (lo - o) * inv;
    let b = (hi - o) * inv;
    let (near, far) = if inv < 0.0 { (b, a) } else { (a, b) };
    if near > *t0 {
        *t0 = near;
    }
    if far < *t1 {
        *t1 = far;
    }
}

impl BvhView<'_> {
    /// The sphere of `spheres` (the list the tree was built over) that `ray`
    /// hits first before `t_max` (which becomes its distance), of equal
    /// distances the first in the list: what a loop over the list returns.
    /// `from` is tested from its surface.
    #[inline(never)]
    pub fn closest<'l>(
        &self,
        spheres: &'l [Listed],
        ray: &Ray,
        t_max: &mut f32,
        from: ObjectId,
    ) -> Option<&'l Listed> {
        let br = BoxRay::new(ray);
        // best: distance t_best at list position best_pos (0 before any
        // hit: then only t < t_best is accepted); spheres are asked for a
        // hit below t_ask, the next float above t_best once there is one,
        // so that a tie with an earlier position is seen
        let mut t_best = *t_max;
        let mut t_ask = *t_max;
        let mut best_pos = 0u16;
        let mut hit = None;
        let mut stack = [(0u16, 0.0f32); STACK];
        let mut sp = 0usize;
        let mut node = 0usize;
        while let Some(n) = self.nodes.get(node) {
            if n.count == 0 {
                let (a, b) = (node + 1, n.index as usize);
                let ta = self.nodes.get(a).and_then(|m| br.enter(m, t_ask));
                let tb = self.nodes.get(b).and_then(|m| br.enter(m, t_ask));
                let next = match (ta, tb) {
                    (Some(ta), Some(tb)) => {
                        let (near, far, tf) = if tb < ta { (b, a, ta) } else { (a, b, tb) };
                        if let Some(slot) = stack.get_mut(sp) {
                            *slot = (far as u16, tf);
                            sp += 1;
                        }
                        Some(near)
                    }
                    (Some(_), None) => Some(a),
                    (None, Some(_)) => Some(b),
                    (None, None) => None,
                };
                if let Some(next) = next {
                    node = next;
                    continue;
                }
            } else {
                let (s, e) = (n.index as usize, n.index as usize + n.count as usize);
                for &it in self.items.get(s..e).unwrap_or(&[]) {
                    let pos = it & !NOT_SHADOW;
                    let Some(l) = spheres.get(pos as usize) else {
                        continue;
                    };
                    let t = if l.id == from {
                        l.sphere.intersect_from_surface(ray, t_ask)
                    } else {
                        l.sphere.intersect(ray, t_ask)
                    };
                    if let Some(t) = t
                        && (t < t_best || pos < best_pos)
                    {
                        t_best = t;
                        t_ask = math::next_up_positive(t);
                        best_pos = pos;
                        hit = Some(l);
                    }
                }
            }
            // next waiting subtree that can still hold a nearer hit
            loop {
                if sp == 0 {
                    *t_max = t_best;
                    return hit;
                }
                sp -= 1;
                if let Some(&(i, t)) = stack.get(sp)
                    && t <= t_ask * SLACK
                {
                    node = i as usize;
                    break;
                }
            }
        }
        *t_max = t_best;
        hit
    }

    /// Whether a sphere of `spheres` (the list the tree was built over) but
    /// `target` blocks `ray` before `t_max`; `from` is tested from its
    /// surface. With `occluders_only`, only the spheres of the analysis'
    /// occluder list are tested.
    #[inline(never)]
    pub fn blocked(
        &self,
        spheres: &[Listed],
        ray: &Ray,
        t_max: f32,
        from: ObjectId,
        target: ObjectId,
        occluders_only: bool,
    ) -> bool {
        let br = BoxRay::new(ray);
        let skip_flag = if occluders_only { NOT_SHADOW } else { 0 };
        let mut stack = [0u16; STACK];
        let mut sp = 0usize;
        let mut node = 0usize;
        loop {
            if let Some(n) = self.nodes.get(node)
                && br.enter(n, t_max).is_some()
            {
                if n.count == 0 {
                    if let Some(slot) = stack.get_mut(sp) {
                        *slot = n.index;
                        sp += 1;
                    }
                    node += 1;
                    continue;
                }
                let (s, e) = (n.index as usize, n.index as usize + n.count as usize);
                for &it in self.items.get(s..e).unwrap_or(&[]) {
                    if it & skip_flag != 0 {
                        continue;
                    }
                    let Some(l) = spheres.get((it & !NOT_SHADOW) as usize) else {
                        continue;
                    };
                    if l.id == target {
                        continue;
                    }
                    let t = if l.id == from {
                        l.sphere.intersect_from_surface(ray, t_max)
                    } else {
                        l.sphere.intersect(ray, t_max)
                    };
                    if t.is_some() {
                        return true;
                    }
                }
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            node = stack.get(sp).copied().unwrap_or(u16::MAX) as usize;
        }
    }
}
