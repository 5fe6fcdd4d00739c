//! A bounding volume hierarchy over a scene's spheres: how a ray skips the
//! spheres it cannot hit when there are many.
//!
//! The tree indexes the analysis' list of spheres ([`Listed`], in view
//! order); a leaf names positions in that list. It is built at scene load
//! without a heap (binned surface-area heuristic, storage sized by the
//! scene's sphere capacity) and is a pure function of the list, so host and
//! board build the same tree.
//!
//! * The tree is 4-wide: a node holds the boxes of its (up to) four
//!   children, axis by axis (four lower and four upper bounds of each axis
//!   side by side), so that one visit tests the four boxes with the same
//!   operations, lane by lane, and the ray's direction picks whole rows of
//!   bounds. (The lanes are computed one by one: the boards have no vector
//!   unit, and the host build turns LLVM's SLP vectoriser off.) It is the
//!   binary surface-area tree collapsed: a node's children
//!   are found by splitting, of its ranges, the one of largest box, until
//!   there are four or none is left to split. A range of more than three
//!   spheres becomes a node; smaller ones are leaves, themselves split
//!   while the node has free lanes (which would be tested all the same): a
//!   leaf holds one to three spheres. A subtree for which the node storage
//!   has no room stays a leaf of all its spheres (slower, the same
//!   answers).
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
/// Ranges deeper than this (in the binary tree the 4-wide one collapses)
/// are split at their middle, whatever the heuristic says.
const SAH_DEPTH: u16 = 40;
/// Ranges this deep in the binary tree are leaves, so that no path of the
/// 4-wide tree has more nodes (middle splits from [`SAH_DEPTH`] on reach
/// leaves of at most 3 of 2¹⁵ spheres 15 levels further: never needed).
const MAX_DEPTH: u16 = 64;
/// Entries of the traversal stacks and of the builder's pending ranges: a
/// depth-first walk keeps at most three waiting children of every node on
/// its path, and the four of the node it opened last.
const STACK: usize = 3 * MAX_DEPTH as usize + 4;
/// Lanes of a node.
const WIDE: usize = 4;
/// Storage units of a node: the lanes of the three axes and the links.
const PARTS: usize = 4;

/// One storage unit of a node: the four children's lower (`b[0]`) and upper
/// (`b[1]`) bounds along one axis, or (the node's fourth unit) the
/// children's links.
///
/// A link is a `u32` kept in the bits of a lane of `b[0]`
/// ([`f32::from_bits`]: copied, never computed with): 0 for an empty lane,
/// an inner child's storage index (a multiple of [`PARTS`], never 0: the
/// root is not a child), or a leaf's first item plus its item count times
/// 2¹⁶.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Lanes {
    b: [[f32; WIDE]; 2],
}

/// A lane without a box: no ray meets it.
const EMPTY_LANES: Lanes = Lanes {
    b: [[f32::INFINITY; WIDE], [f32::NEG_INFINITY; WIDE]],
};

/// A box: lower and upper corners.
type Aabb = ([f32; 3], [f32; 3]);

/// The link of a leaf of items `start..end`.
fn leaf_link(start: u16, end: u16) -> u32 {
    u32::from(start) | u32::from(end - start) << 16
}

/// The tree over a scene's listed spheres (see the module docs), with room
/// for `S` spheres.
#[derive(Clone, Debug)]
pub struct Bvh<const S: usize> {
    /// The nodes, [`PARTS`] units each; the root first.
    parts: Vec<Lanes, S>,
    /// Positions in the sphere list (with [`NOT_SHADOW`]), leaf by leaf.
    items: Vec<u16, S>,
    depth: u16,
}

/// A borrowed [`Bvh`], independent of its capacity: what the queries use.
#[derive(Clone, Copy, Debug)]
pub struct BvhView<'a> {
    parts: &'a [Lanes],
    items: &'a [u16],
}

/// A range of items waiting to become a node.
#[derive(Clone, Copy)]
struct Pending {
    start: u16,
    end: u16,
    /// Depth in the binary tree (the root's range: 1).
    depth: u16,
    /// Depth in the 4-wide tree (the root: 1).
    wide_depth: u16,
    /// Where its link goes: storage unit times [`WIDE`] plus lane
    /// (`u32::MAX`: the root).
    slot: u32,
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
        parts: Vec::new(),
        items: Vec::new(),
        depth: 0,
    };

    /// Drops the tree.
    pub fn clear(&mut self) {
        self.parts.clear();
        self.items.clear();
        self.depth = 0;
    }

    /// Number of nodes (0: no tree).
    pub fn len(&self) -> usize {
        self.parts.len() / PARTS
    }

    /// Whether there is no tree.
    pub fn is_empty(&self) -> bool {
        self.parts.is_empty()
    }

    /// Number of nodes on the longest path from the root to a leaf's
    /// parent.
    pub fn depth(&self) -> u16 {
        self.depth
    }

    /// The tree borrowed, or `None` if there is none.
    pub fn view(&self) -> Option<BvhView<'_>> {
        // a firmware built without the tree's code has none
        (!cfg!(micropt_no_bvh) && !self.parts.is_empty()).then_some(BvhView {
            parts: &self.parts,
            items: &self.items,
        })
    }

    /// Builds the tree over `spheres` (replacing any previous one); the
    /// spheres whose index is not in `shadow` (ascending scene indices: the
    /// analysis' occluder list) are marked as never blocking a shadow ray.
    /// No tree is built for an empty list, one of more than 2¹⁵ − 1
    /// spheres, or a capacity below one node.
    pub fn build(&mut self, spheres: &[Listed], shadow: &[u16]) {
        self.clear();
        let n = spheres.len();
        if n == 0 || n >= NOT_SHADOW as usize || n > S || S < PARTS {
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
        let mut pending: Vec<Pending, STACK> = Vec::new();
        let mut next = Some(Pending {
            start: 0,
            end: n as u16,
            depth: 1,
            wide_depth: 1,
            slot: u32::MAX,
        });
        while let Some(p) = next.take().or_else(|| pending.pop()) {
            self.make_node(spheres, p, &mut pending);
        }
    }

    /// Writes `link` into the lane `slot` (see [`Pending::slot`]).
    fn set_link(&mut self, slot: u32, link: u32) {
        let (unit, lane) = ((slot / WIDE as u32) as usize, (slot % WIDE as u32) as usize);
        if let Some(l) = self.parts.get_mut(unit).and_then(|u| u.b[0].get_mut(lane)) {
            *l = f32::from_bits(link);
        }
    }

    /// Appends the node of the range `p` (its children: up to four ranges
    /// split from it, the range itself if it is a leaf) and queues its inner
    /// children; without room for the node, the range becomes a leaf of its
    /// parent.
    fn make_node(&mut self, spheres: &[Listed], p: Pending, pending: &mut Vec<Pending, STACK>) {
        let me = self.parts.len();
        if S - me < PARTS {
            self.set_link(p.slot, leaf_link(p.start, p.end));
            return;
        }
        self.set_link(p.slot, me as u32);
        self.depth = self.depth.max(p.wide_depth);
        // children: (start, end, binary depth, box, whether it can split)
        let mut kids: Vec<(u16, u16, u16, Aabb), WIDE> = Vec::new();
        let _ = kids.push((
            p.start,
            p.end,
            p.depth,
            self.range_box(spheres, p.start, p.end),
        ));
        // a child of more than 3 spheres becomes a node
        let splits = |k: &(u16, u16, u16, Aabb)| k.1 - k.0 > 3 && k.2 < MAX_DEPTH;
        while !kids.is_full() {
            // the child of largest box among those of more than 3 spheres,
            // else among those of 2 or 3 (the first of equal ones): lanes
            // left free would be tested all the same, so small leaves are
            // split too
            let mut pick = None;
            let mut best = (false, f32::NEG_INFINITY);
            for (i, k) in kids.iter().enumerate() {
                let key = (splits(k), half_area(&k.3));
                if k.1 - k.0 >= 2 && k.2 < MAX_DEPTH && key > best {
                    (pick, best) = (Some(i), key);
                }
            }
            let Some((i, (s, e, d))) = pick.and_then(|i| kids.get(i).map(|k| (i, (k.0, k.1, k.2))))
            else {
                break;
            };
            let mid = self.split(spheres, s, e, d);
            let (bl, br) = (
                self.range_box(spheres, s, mid),
                self.range_box(spheres, mid, e),
            );
            if let Some(k) = kids.get_mut(i) {
                *k = (s, mid, d + 1, bl);
            }
            let _ = kids.push((mid, e, d + 1, br));
        }
        let mut axes = [EMPTY_LANES; 3];
        let mut links = Lanes {
            b: [[0.0; WIDE]; 2],
        };
        let base = (me + PARTS - 1) as u32 * WIDE as u32;
        for (lane, k) in kids.iter().enumerate() {
            let (lo, hi) = k.3;
            for (a, (l, h)) in axes.iter_mut().zip(lo.into_iter().zip(hi)) {
                let [al, ah] = &mut a.b;
                if let (Some(al), Some(ah)) = (al.get_mut(lane), ah.get_mut(lane)) {
                    (*al, *ah) = (l, h);
                }
            }
            let link = if splits(k) {
                let kid = Pending {
                    start: k.0,
                    end: k.1,
                    depth: k.2,
                    wide_depth: p.wide_depth + 1,
                    slot: base + lane as u32,
                };
                // a full queue (never: see STACK) leaves a leaf
                if pending.push(kid).is_ok() {
                    continue;
                }
                leaf_link(k.0, k.1)
            } else {
                leaf_link(k.0, k.1)
            };
            if let Some(l) = links.b[0].get_mut(lane) {
                *l = f32::from_bits(link);
            }
        }
        // S − me ≥ PARTS: room for the four units
        for u in axes.into_iter().chain([links]) {
            let _ = self.parts.push(u);
        }
    }

    /// The box of the items `start..end`.
    fn range_box(&self, spheres: &[Listed], start: u16, end: u16) -> Aabb {
        let mut bounds = EMPTY_BOX;
        for &it in self.items.get(start as usize..end as usize).unwrap_or(&[]) {
            if let Some(l) = spheres.get((it & !NOT_SHADOW) as usize) {
                let (lo, hi) = sphere_box(l);
                grow(&mut bounds, &lo, &hi);
            }
        }
        bounds
    }

    /// Partitions the items `start..end` (more than one) in two by the
    /// binned surface-area heuristic (at depth [`SAH_DEPTH`] and beyond, or
    /// when their centres coincide: at the middle) and returns where the
    /// second part starts.
    fn split(&mut self, spheres: &[Listed], start: u16, end: u16, depth: u16) -> u16 {
        let (s, e) = (start as usize, end as usize);
        let sphere_at = |item: u16| spheres.get((item & !NOT_SHADOW) as usize);
        let mut centres = EMPTY_BOX;
        for &it in self.items.get(s..e).unwrap_or(&[]) {
            if let Some(l) = sphere_at(it) {
                let c = [l.sphere.center.x, l.sphere.center.y, l.sphere.center.z];
                grow(&mut centres, &c, &c);
            }
        }
        let count = end - start;
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
            return middle;
        }
        // parts of at least 2 spheres (1 when splitting a leaf's 2 or 3)
        let least = if count > 3 { 2 } else { 1 };
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
                *rc = if cnt >= least {
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
            if cnt >= least {
                let cost = half_area(&acc) * cnt as f32 + rc;
                if cost < best_cost {
                    best_cost = cost;
                    best = j;
                }
            }
        }
        if best == 0 {
            return middle;
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
        i as u16
    }
}

/// A ray prepared for box tests: origin, reciprocal direction, and for each
/// axis the bound it meets first (0: the lower, 1: the upper, when it runs
/// toward lower values).
#[derive(Clone, Copy)]
struct BoxRay {
    o: [f32; 3],
    inv: [f32; 3],
    near: [usize; 3],
}

impl BoxRay {
    fn new(ray: &Ray) -> Self {
        let (o, d) = (ray.origin, ray.dir);
        let inv = [1.0 / d.x, 1.0 / d.y, 1.0 / d.z];
        Self {
            o: [o.x, o.y, o.z],
            inv,
            near: [
                usize::from(inv[0] < 0.0),
                usize::from(inv[1] < 0.0),
                usize::from(inv[2] < 0.0),
            ],
        }
    }

    /// For the four boxes of a node (its units `x`, `y`, `z`): the ray
    /// parameters where the ray enters them, and a mask of those it meets
    /// within `[0, t_max]` (lengthened by [`SLACK`]), bit `k` for lane `k`.
    /// A NaN slab bound (the origin on a slab plane of an axis the ray does
    /// not move along) leaves the interval unchanged.
    #[inline(always)]
    fn enter(&self, x: &Lanes, y: &Lanes, z: &Lanes, t_max: f32) -> ([f32; WIDE], u32) {
        let mut t0 = [0.0f32; WIDE];
        let mut t1 = [t_max; WIDE];
        let [ox, oy, oz] = self.o;
        let [ix, iy, iz] = self.inv;
        let [nx, ny, nz] = self.near;
        slabs(x, nx, ox, ix, &mut t0, &mut t1);
        slabs(y, ny, oy, iy, &mut t0, &mut t1);
        slabs(z, nz, oz, iz, &mut t0, &mut t1);
        let mut mask = 0;
        for (k, (a, b)) in t0.iter().zip(t1).enumerate() {
            mask |= u32::from(*a <= b * SLACK) << k;
        }
        (t0, mask)
    }
}

/// Narrows the ray intervals `t0..t1` of the four lanes to their slabs
/// along one axis (origin `o`, reciprocal direction `inv`, `near`: the
/// bound met first, see [`BoxRay`]); a NaN bound changes nothing. (Whole
/// rows selected by an index, not lane by lane: the four lanes load and
/// compute together.)
#[inline(always)]
fn slabs(u: &Lanes, near: usize, o: f32, inv: f32, t0: &mut [f32; WIDE], t1: &mut [f32; WIDE]) {
    let (near, far) = (&u.b[near & 1], &u.b[(near ^ 1) & 1]);
    for (((a, b), n), f) in t0.iter_mut().zip(t1.iter_mut()).zip(near).zip(far) {
        *a = math::max((n - o) * inv, *a);
        *b = math::min((f - o) * inv, *b);
    }
}

/// The link of lane `k` of a links unit (see [`Lanes`]).
#[inline(always)]
fn link(links: &Lanes, k: usize) -> u32 {
    links.b[0].get(k).map_or(0, |l| l.to_bits())
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
        // (link, ray parameter where its box starts), the nearest on top
        let mut stack: Vec<(u32, f32), STACK> = Vec::new();
        let mut node = 0usize;
        loop {
            // the nearest child met goes next, the others wait (in lane
            // order)
            let mut next = None;
            if let Some([x, y, z, l]) = self.parts.get(node..node + PARTS) {
                let (t0, mask) = br.enter(x, y, z, t_ask);
                // the mask is read as a whole (its lowest bit each time)
                let mut bits = mask;
                let mut t_next = f32::INFINITY;
                while bits != 0 {
                    let k = bits.trailing_zeros() as usize & (WIDE - 1);
                    bits &= bits - 1;
                    let (r, t) = (link(l, k), t0.get(k).copied().unwrap_or(0.0));
                    if r == 0 {
                        continue;
                    }
                    // at most three waiting children per node of the path
                    if t < t_next {
                        if let Some(n) = next {
                            let _ = stack.push((n, t_next));
                        }
                        (next, t_next) = (Some(r), t);
                    } else {
                        let _ = stack.push((r, t));
                    }
                }
            }
            // that child, else the nearest waiting one that can still hold
            // a nearer hit: a leaf is tested here, an inner node opened
            loop {
                let r = match next.take() {
                    Some(r) => r,
                    None => {
                        let Some((r, t)) = stack.pop() else {
                            *t_max = t_best;
                            return hit;
                        };
                        if !(t <= t_ask * SLACK) {
                            continue;
                        }
                        r
                    }
                };
                let (s, count) = ((r & 0xffff) as usize, (r >> 16) as usize);
                if count == 0 {
                    node = s;
                    break;
                }
                for &it in self.items.get(s..s + count).unwrap_or(&[]) {
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
        }
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
        let mut stack: Vec<u32, STACK> = Vec::new();
        let mut node = 0usize;
        loop {
            if let Some([x, y, z, l]) = self.parts.get(node..node + PARTS) {
                let (_, mut bits) = br.enter(x, y, z, t_max);
                // the mask read as a whole (see `closest`)
                while bits != 0 {
                    let k = bits.trailing_zeros() as usize & (WIDE - 1);
                    bits &= bits - 1;
                    let r = link(l, k);
                    let (s, count) = ((r & 0xffff) as usize, (r >> 16) as usize);
                    if count == 0 {
                        // an inner node (0: an empty lane); at most three
                        // waiting children per node of the path
                        if r != 0 {
                            let _ = stack.push(r);
                        }
                        continue;
                    }
                    for &it in self.items.get(s..s + count).unwrap_or(&[]) {
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
            }
            match stack.pop() {
                Some(r) => node = r as usize,
                None => return false,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Sphere;

    /// 16 clusters of two pairs of spheres (the second pair an exact copy of
    /// the first: equal ray parameters at different list positions), far
    /// apart on a 4 × 4 grid.
    fn clusters() -> Vec<Listed, 64> {
        let mut out = Vec::new();
        for c in 0..16 {
            let base = Vec3::new((c % 4) as f32 * 20.0, 0.0, (c / 4) as f32 * 20.0);
            for copy in 0..2 {
                for k in 0..2 {
                    let centre = base + Vec3::new(k as f32 * 3.0, 0.0, 0.0);
                    let i = out.len();
                    let l = Listed {
                        sphere: Sphere::new(centre, 1.0, copy),
                        id: ObjectId::sphere(i),
                    };
                    assert!(out.push(l).is_ok());
                }
            }
        }
        out
    }

    /// Law checked: the tree answers as the loop over the list does (the
    /// nearest hit, of equal ones the first in the list; any blocking
    /// sphere) also when its storage runs out and subtrees stay leaves of
    /// many spheres: 64 spheres in clusters that need 21 nodes, where
    /// `Bvh<64>` has room for 16.
    #[test]
    fn a_full_node_storage_leaves_big_leaves_and_the_same_answers() {
        let list = clusters();
        let mut tree = Bvh::<64>::EMPTY;
        tree.build(&list, &[]);
        assert_eq!(tree.len(), 16, "the storage is full");
        let mut roomy = Bvh::<256>::EMPTY;
        roomy.build(&list, &[]);
        assert!(roomy.len() > 16, "the clusters need more nodes than 16");
        let view = tree.view().unwrap();
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut hits = 0;
        for _ in 0..4000 {
            let o = Vec3::new(
                next() * 80.0 - 10.0,
                next() * 6.0 - 3.0,
                next() * 80.0 - 10.0,
            );
            let aim = Vec3::new(next() * 70.0, next() * 2.0 - 1.0, next() * 70.0);
            let ray = Ray::new(o, (aim - o).normalize());
            let (mut t_loop, mut best) = (f32::INFINITY, None);
            for (i, l) in list.iter().enumerate() {
                if let Some(t) = l.sphere.intersect(&ray, t_loop) {
                    (t_loop, best) = (t, Some(i));
                }
            }
            let mut t_tree = f32::INFINITY;
            let got = view.closest(&list, &ray, &mut t_tree, ObjectId::NONE);
            let got = got.map(|l| list.iter().position(|m| core::ptr::eq(m, l)).unwrap());
            assert_eq!((got, t_tree.to_bits()), (best, t_loop.to_bits()));
            let blocked = view.blocked(&list, &ray, 50.0, ObjectId::NONE, ObjectId::NONE, false);
            assert_eq!(blocked, best.is_some() && t_loop < 50.0);
            hits += usize::from(best.is_some());
        }
        assert!(hits > 400, "{hits} rays of 4000 hit a sphere");
    }
}
