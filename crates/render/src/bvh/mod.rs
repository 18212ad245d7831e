//! The bounding volume hierarchy: which primitive a ray meets first, without
//! testing every primitive.
//!
//! What: a binary tree of axis-aligned boxes over every primitive of a scene
//! (analytic shapes and triangles together), in f64 like the rest of the
//! renderer (scenes are in metres with 0.1 mm features). [`Bvh::nearest`]
//! returns exactly what a linear scan of the primitives in file order
//! returns — the hit with the smallest t, and of equal t the primitive with
//! the smallest index — and [`Bvh::occluded`] whether anything lies on a
//! shadow ray.
//!
//! Why: a mesh scene holds up to a million triangles, and a linear scan costs
//! O(n) per ray. The booth scenes hold a dozen primitives, where the scan is
//! faster than any traversal: scenes below [`LINEAR_SCAN_BELOW`] primitives
//! keep it (see `Prepared::new` in the integrator).
//!
//! How:
//! - Build: top-down with the surface area heuristic (SAH; MacDonald & Booth
//!   1990), binned as in Wald 2007, "On fast construction of SAH-based
//!   bounding volume hierarchies" (IEEE Symp. on Interactive Ray Tracing):
//!   per node the primitives' centroids fall into [`BINS`] equal bins along
//!   each axis, and the split between bins minimising
//!   C_trav + C_isect·(A_L·N_L + A_R·N_R)/A is taken unless a leaf
//!   (C_isect·N) is cheaper. Subtrees of more than [`PARALLEL_BUILD_MIN`]
//!   primitives are built on two threads (`rayon::join`); the node order is
//!   that of the sequential depth-first build, so the tree is the same on
//!   any number of threads (and so is every render).
//! - Conservative boxes: every primitive's box ([`Shape::bounds`]) is padded
//!   by [`PAD_RELATIVE`]·(1 m + its largest coordinate magnitude), ~1 nm in a
//!   booth. A ray then crosses at least that padding before reaching the
//!   primitive, which dwarfs the rounding of the slab test (~1e-16·t), so no
//!   box rejects a hit its primitive's own test would report, and shared
//!   triangle edges stay watertight through the tree.
//! - Layout: a node is 32 bytes (its box in f32, rounded outward so it
//!   still holds the padded f64 box, and two u32); the two children of a
//!   node sit side by side in one 64-byte-aligned pair, so a visit that
//!   tests both boxes reads one cache line. Pairs are in depth-first order.
//!   A leaf's primitives are a contiguous range of 80-byte slots holding the
//!   primitive index and, for a triangle, a copy of its f64 vertices (not
//!   the 176-byte `Primitive`), so a leaf's triangles are read in sequence;
//!   analytic shapes are tested through the scene's list of record.
//! - Four-wide: the binary tree is then collapsed into a BVH4 (each node
//!   opens its interior descendant with the largest box until it has four
//!   children; Wald et al. 2008, "Getting rid of packets"), nodes in
//!   depth-first order, 64 bytes each (one cache line): the four children's
//!   f32 boxes quantised outward to 8 bits per coordinate relative to the
//!   node's box (so still conservative; see `Wide`), in
//!   structure-of-arrays layout so the four slab tests are one loop over the
//!   lanes (in f64). The binary pairs are kept for [`Bvh::depth`] and the
//!   determinism test.
//!   Memory for 1 M triangles: 93 MB (11 MB binary pairs, 5.7 MB four-wide
//!   nodes, 76 MB slots) besides the scene's own primitives (176 MB).
//! - Memory: the nodes and slots are on transparent huge pages (see
//!   `huge_pages`), the children a node's test enters are prefetched
//!   together, and the nearest triangle's normal is recomputed from its slot
//!   rather than read from the shape list.
//! - Traversal: the inverse direction and the watertight test's shear
//!   ([`ShearedRay`]) are computed once per ray; at a four-wide node the
//!   four boxes are tested together, the children entered before the
//!   current nearest hit are sorted by entry distance (ties in lane order),
//!   the nearest is visited and the others are pushed with their entry
//!   distances, farthest first; popped children entered beyond the current
//!   nearest hit are skipped. Shadow rays stop at the first hit. The prune
//!   tests (entry ≤ best t, popped entry ≤ best t) are those of the binary
//!   traversal, so the answer is the linear scan's as before.
//!
//! Binary → four-wide, measured back to back with `cargo bench --bench bvh
//! -- --json` (one thread, medians of 5, the 2-core machine loaded ~3.4 by
//! two other builds): rays/s 1 k 1.85 M → 1.89 M, 100 k 0.69 M → 0.73 M,
//! 1 M 0.29 M → 0.32 M (another run 0.35 M); 1 k / 1 M ratio 6.4 → 5.9.
//! The 1 M mesh is bound by memory: random rays, ~90 MB of tree, and leaves
//! of ~4 triangles in 80-byte f64 slots (5 cache lines per leaf); per ray it
//! visits 13.5 wide nodes and tests 10.9 primitives, against 6.3 and 10.6 on
//! the 1 k mesh (counted with temporary counters), so most of the 1 M / 1 k
//! gap is cache misses. Tried and reverted: TRAVERSAL_COST 2 (100 k 0.64 M,
//! 1 M 0.31 M rays/s) and 8 (0.65 M, 0.27 M) with the four-wide traversal.
//! Then, each step measured against the previous (`nice -n -20`, 3
//! alternating runs, the machine loaded ~7 by two builds, so absolute
//! numbers are low): the normal from the slot and prefetching raised 1 M by
//! ~35 % (`perf record` had put 12 % of the trace on the shape-list read);
//! huge pages by a further 10–18 %; quantised one-line nodes by 3 % on 1 M
//! and −7 % on 1 k. 1 k / 1 M ratio: 4.6–6.0 → 3.8–4.4 → 3.5–3.7 → 3.0–3.2.
//! On the quiet machine, all four steps against the binary before them
//! (`cargo bench --bench bvh -- --json`, 3 alternating runs, medians):
//! 1 M 0.40 M → 0.67 M rays/s (+68 %), 100 k 0.89 M → 1.19 M, 1 k 2.25 M →
//! 1.97 M (−12 %: the dequantisation and prefetches cost a compute-bound
//! traversal); 1 k / 1 M ratio 5.6 → 2.9; build of 1 M unchanged (0.45 s).
//! Not tried: compressing the slots (f32 vertices would lose the f64
//! answer).
//!
//! Crate or own — own, for exactness, not for speed. Measured with
//! `cargo bench --bench bvh --features bench-obvhs -- --json` (one thread
//! tracing, medians of 5; the 2-core machine shared with two builds, so
//! absolute numbers are ±30 %; all rows of one run):
//!
//! | triangles | own f64: build s, rays/s | obvhs BVH2 f32 | obvhs CWBVH f32 |
//! |---|---|---|---|
//! | 1 k   | 0.0004, 1.22 M | 0.0005, 2.21 M | 0.0004, 2.47 M |
//! | 100 k | 0.059, 0.41 M  | 0.066, 0.57 M  | 0.076, 0.76 M  |
//! | 1 M   | 1.21, 0.21 M   | 1.03, 0.29 M   | 0.82, 0.58 M   |
//!
//! (That table predates the four-wide traversal.) `obvhs` 0.4's eight-wide CWBVH traces 2–3× faster and builds 1.5×
//! faster. It is not used because (1) it is f32 only: its boxes are rounded
//! to nearest, not outward, and its traversal culls by f32 distances, so it
//! cannot promise the f64 linear scan's answer (on the 1 M mesh its nearest
//! triangle differed for 0.004 % of the rays), nor the tie rule the
//! renderer's determinism relies on; (2) it needs glam ≥ 0.33 while the
//! renderer uses glam 0.30 (a second glam, or an upgrade of every module);
//! (3) analytic shapes would go through its closure API with f32 t. `bvh`
//! pulls in nalgebra. Part of the gap was the node width (now four-wide,
//! see above); the rest is the f64 slots and the f64 slab tests.

use std::fmt;
use std::sync::{Arc, OnceLock};

use glam::DVec3;

use super::geometry::{triangle_normal, Aabb, Hit, Ray, Shape, ShearedRay};
use super::huge_pages::vec_with_huge_pages;

/// Scenes with fewer primitives are traced by a linear scan: below this the
/// scan is faster than a traversal. Measured: in `benches/bvh.rs`
/// (`crossover`, a booth of walls and small mixed shapes) the two are equal
/// at 16–24 primitives and the BVH is ~1.9× faster at 32; the booth scenes
/// with a 24-patch chart (29 primitives) rendered 10 % slower with the BVH
/// (`lightbooth render scenes/red.toml`, 1 thread, median of 7), so they
/// keep the scan.
pub const LINEAR_SCAN_BELOW: usize = 32;

/// Centroid bins per axis of the binned SAH (Wald 2007 uses 16–32).
pub const BINS: usize = 16;

/// Leaves hold at most this many primitives (unless they are all alike).
pub const MAX_LEAF: usize = 8;

/// Cost of one node visit relative to one primitive test (the SAH's
/// C_trav / C_isect). Measured, not guessed: on the 1 M-triangle torus of
/// `benches/bvh.rs` a node visit is mostly a cache miss, and 4 (leaves of
/// ~4 triangles, contiguous in memory) traced 1.5–1.7× faster than 1
/// (leaves of ~2), at the same speed for 1 k triangles.
const TRAVERSAL_COST: f64 = 4.0;

/// Below this depth splits follow the SAH; deeper (a pathological scene),
/// they halve the primitives, so the tree depth stays below [`STACK`].
const MAX_SAH_DEPTH: usize = 64;

/// Traversal stack entries: ≥ MAX_SAH_DEPTH + log₂ of any primitive count.
const STACK: usize = 128;

/// Subtrees with more primitives are built in parallel.
pub const PARALLEL_BUILD_MIN: usize = 32 * 1024;

/// Relative padding of every primitive's box (see the module doc).
pub const PAD_RELATIVE: f64 = 1e-9;

/// Marks a slot holding a triangle (its vertices are in the slot).
const TRIANGLE_BIT: u32 = 1 << 31;

/// An indexable list of shapes: the scene's primitives, or bare shapes.
pub trait ShapeList {
    fn len(&self) -> usize;
    fn shape(&self, i: usize) -> &Shape;
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

impl ShapeList for [Shape] {
    #[inline]
    fn len(&self) -> usize {
        <[Shape]>::len(self)
    }
    #[inline]
    fn shape(&self, i: usize) -> &Shape {
        &self[i]
    }
}

/// A node: its box, stored in f32 rounded outward (so it still contains the
/// padded f64 box; 32 bytes, two siblings per 64-byte cache line).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
struct Node {
    min: [f32; 3],
    max: [f32; 3],
    /// Leaf: first slot; interior: the pair holding its two children.
    index: u32,
    /// Leaf: number of slots (≥ 1); interior: 0.
    count: u32,
}

/// Two siblings, aligned to a cache line: a visit tests both boxes at once.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(64))]
struct Pair([Node; 2]);

/// Children per node of the traversed (collapsed) tree.
const WIDTH: usize = 4;

/// Traversal stack entries of the four-wide tree: each level leaves at most
/// WIDTH − 1 children pushed, over at most STACK levels.
const WIDE_STACK: usize = (WIDTH - 1) * STACK;

/// Marks an unused lane of a [`Wide`] node.
const EMPTY_LANE: u8 = u8::MAX;

/// A node of the four-wide tree that is traversed: up to four children's
/// boxes, quantised to 8 bits per coordinate relative to the node's own box
/// (as in Ylitie et al. 2017, "Efficient incoherent ray traversal on GPUs
/// through compressed wide BVHs", and Embree's quantised nodes), so the node
/// fits in one 64-byte cache line. A lane's box on `axis` is
/// `origin + q · 2^exp` with `q` in `qmin..=qmax`; the quantisation rounds
/// outward, so it holds the child's f32 box, which holds the padded f64 box.
/// Lanes are in structure-of-arrays layout so the four slab tests run side
/// by side.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
struct Wide {
    /// The lower corner of the union of the lanes' boxes.
    origin: [f32; 3],
    /// Per axis, the power of two of one quantisation step.
    exp: [i8; 3],
    qmin: [[u8; WIDTH]; 3],
    qmax: [[u8; WIDTH]; 3],
    /// Leaf child: number of slots (1..=MAX_LEAF); interior child: 0;
    /// unused: [`EMPTY_LANE`].
    count: [u8; WIDTH],
    /// Leaf child: first slot; interior child: its wide node.
    index: [u32; WIDTH],
}

impl Wide {
    const EMPTY: Wide = Wide {
        origin: [0.0; 3],
        exp: [0; 3],
        qmin: [[0; WIDTH]; 3],
        qmax: [[0; WIDTH]; 3],
        count: [EMPTY_LANE; WIDTH],
        index: [0; WIDTH],
    };

    /// A wide node over up to four children (binary nodes, whose f32 boxes
    /// are quantised outward); `index[l]` is filled in by the caller.
    fn quantised(children: &[Node]) -> Wide {
        let mut w = Wide::EMPTY;
        for axis in 0..3 {
            let lo = children.iter().map(|c| c.min[axis]).fold(f32::INFINITY, f32::min);
            let hi = children.iter().map(|c| c.max[axis]).fold(f32::NEG_INFINITY, f32::max);
            // The smallest step with (hi − lo)/step ≤ 255 (differences of
            // f32 values are exact in f64 at these magnitudes).
            let extent = hi as f64 - lo as f64;
            let mut exp = if extent > 0.0 {
                ((extent / 255.0).log2().ceil() as i32).clamp(-126, 127)
            } else {
                -126
            };
            while extent / 2f64.powi(exp) > 255.0 {
                exp += 1;
            }
            let step = 2f64.powi(exp);
            w.origin[axis] = lo;
            w.exp[axis] = exp as i8;
            for (l, c) in children.iter().enumerate() {
                w.qmin[axis][l] = ((c.min[axis] as f64 - lo as f64) / step).floor() as u8;
                w.qmax[axis][l] = ((c.max[axis] as f64 - lo as f64) / step).ceil().min(255.0) as u8;
            }
        }
        for (l, c) in children.iter().enumerate() {
            w.count[l] = c.count as u8;
        }
        w
    }

    /// The children the ray enters before `t_max`, nearest first (equal
    /// distances in lane order): their number and (distance, lane). The f64
    /// slab test of [`Node::entry`] on the dequantised boxes: per axis,
    /// t = (origin − o)·inv + q·(2^exp·inv), which differs from
    /// (origin + q·2^exp − o)·inv by a few f64 roundings (~1e-16 of t),
    /// dwarfed by the boxes' padding.
    #[inline(always)]
    fn entries(&self, o: [f64; 3], inv: [f64; 3], t_max: f64) -> (usize, [(f64, usize); WIDTH]) {
        let mut near = [0.0f64; WIDTH];
        let mut far = [t_max; WIDTH];
        for axis in 0..3 {
            let base = (self.origin[axis] as f64 - o[axis]) * inv[axis];
            let step = f64::from_bits(((self.exp[axis] as i64 + 1023) as u64) << 52) * inv[axis];
            for l in 0..WIDTH {
                let a = base + self.qmin[axis][l] as f64 * step;
                let b = base + self.qmax[axis][l] as f64 * step;
                near[l] = near[l].max(a.min(b));
                far[l] = far[l].min(a.max(b));
            }
        }
        let mut hits = [(0.0, 0); WIDTH];
        let mut n = 0;
        for l in 0..WIDTH {
            if near[l] <= far[l] && self.count[l] != EMPTY_LANE {
                // Insertion: nearest first, a tie after the earlier lane.
                let mut i = n;
                while i > 0 && hits[i - 1].0 > near[l] {
                    hits[i] = hits[i - 1];
                    i -= 1;
                }
                hits[i] = (near[l], l);
                n += 1;
            }
        }
        (n, hits)
    }
}

/// A pushed child: where it is and the distance at which the ray enters it.
#[derive(Clone, Copy, Debug, Default)]
struct Pending {
    index: u32,
    count: u32,
    t_enter: f64,
}

/// Collapses the binary tree below `node` (an interior node) into four-wide
/// nodes appended to `wide` in depth-first order; returns its wide index.
/// Of its descendants, the interior one with the largest box is opened until
/// there are four (the usual BVH2 → BVH4 collapse); first of equal areas wins.
fn collapse(pairs: &[Pair], node: &Node, wide: &mut Vec<Wide>) -> u32 {
    let area = |n: &Node| {
        let d = [0, 1, 2].map(|a| n.max[a] as f64 - n.min[a] as f64);
        d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
    };
    let mut children: Vec<Node> = pairs[node.index as usize].0.to_vec();
    while children.len() < WIDTH {
        let mut open: Option<(usize, f64)> = None;
        for (i, c) in children.iter().enumerate() {
            if c.count == 0 && open.is_none_or(|(_, a)| area(c) > a) {
                open = Some((i, area(c)));
            }
        }
        let Some((i, _)) = open else { break };
        let [a, b] = pairs[children[i].index as usize].0;
        children.splice(i..=i, [a, b]);
    }
    let me = wide.len();
    wide.push(Wide::EMPTY);
    let mut w = Wide::quantised(&children);
    for (l, c) in children.iter().enumerate() {
        w.index[l] = if c.count > 0 { c.index } else { collapse(pairs, c, wide) };
    }
    wide[me] = w;
    me as u32
}

/// The largest f32 ≤ x.
fn f32_down(x: f64) -> f32 {
    let f = x as f32;
    if f as f64 > x {
        f.next_down()
    } else {
        f
    }
}

/// The smallest f32 ≥ x.
fn f32_up(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) < x {
        f.next_up()
    } else {
        f
    }
}

impl Node {
    fn new(b: &Aabb, index: u32, count: u32) -> Node {
        Node {
            min: b.min.to_array().map(f32_down),
            max: b.max.to_array().map(f32_up),
            index,
            count,
        }
    }

    /// The distance at which the ray enters this box, if it does before
    /// `t_max` (slab test in f64; `inv` = 1/direction, ±∞ for zero
    /// components; `f64::min`/`max` drop the NaN of 0·∞).
    #[inline(always)]
    fn entry(&self, o: DVec3, inv: DVec3, t_max: f64) -> Option<f64> {
        let (min, max) = (self.min, self.max);
        let (ax, bx) = ((min[0] as f64 - o.x) * inv.x, (max[0] as f64 - o.x) * inv.x);
        let (ay, by) = ((min[1] as f64 - o.y) * inv.y, (max[1] as f64 - o.y) * inv.y);
        let (az, bz) = ((min[2] as f64 - o.z) * inv.z, (max[2] as f64 - o.z) * inv.z);
        let near = ax.min(bx).max(ay.min(by)).max(az.min(bz)).max(0.0);
        let far = ax.max(bx).min(ay.max(by)).min(az.max(bz)).min(t_max);
        if near <= far {
            Some(near)
        } else {
            None
        }
    }
}

/// A leaf entry: the primitive index ([`TRIANGLE_BIT`] marks a triangle)
/// and a triangle's vertices (zero for analytic shapes), 80 bytes.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
struct Slot {
    vertices: [DVec3; 3],
    tagged: u32,
}

/// A primitive during the build: its padded box and index.
#[derive(Clone, Copy, Debug)]
struct BuildRef {
    bounds: Aabb,
    prim: u32,
}

/// A bounding volume hierarchy over a list of shapes (see the module doc).
pub struct Bvh {
    root: Node,
    /// Children of the interior nodes, in depth-first order.
    pairs: Vec<Pair>,
    /// The binary tree collapsed four-wide: what is traversed (root at 0).
    wide: Vec<Wide>,
    /// The leaves' primitives, each leaf a contiguous range.
    slots: Vec<Slot>,
    /// Of the boxes and triangles it was built from (see [`fingerprint`]).
    fingerprint: u64,
    /// True when every triangle's stored normal is [`triangle_normal`] of
    /// its vertices (always, for triangles made by [`Shape::triangle`]): the
    /// nearest hit's normal is then recomputed from its slot, which is in
    /// the cache, instead of read from the shape list, which on a 1 M-triangle
    /// mesh is a cache miss per ray (12 % of the trace time, measured with
    /// `perf record` on `cargo bench --bench bvh -- --json`).
    normals_from_vertices: bool,
}

impl fmt::Debug for Bvh {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Bvh")
            .field("primitives", &self.slots.len())
            .field("nodes", &self.node_count())
            .finish()
    }
}

/// The box of a shape as the BVH uses it: padded (see the module doc).
fn padded_bounds(shape: &Shape) -> Aabb {
    let b = shape.bounds();
    let magnitude = b.min.abs().max(b.max.abs()).max_element();
    let pad = DVec3::splat(PAD_RELATIVE * (1.0 + magnitude));
    Aabb {
        min: b.min - pad,
        max: b.max + pad,
    }
}

/// A hash of what a BVH depends on: every shape's box and every triangle's
/// vertices (analytic shapes are tested through the list itself, so only
/// their boxes matter). A cached BVH is reused only when this matches.
pub fn fingerprint<S: ShapeList + ?Sized>(shapes: &S) -> u64 {
    // FxHash's word mix (rustc's hasher): fast and plenty for change detection.
    let mut h = shapes.len() as u64;
    let mut mix = |x: f64| h = (h.rotate_left(5) ^ x.to_bits()).wrapping_mul(0x517c_c1b7_2722_0a95);
    for i in 0..shapes.len() {
        match *shapes.shape(i) {
            Shape::Triangle { p0, p1, p2, .. } => {
                for v in [p0, p1, p2] {
                    v.to_array().into_iter().for_each(&mut mix);
                }
            }
            ref s => {
                let b = s.bounds();
                b.min.to_array().into_iter().for_each(&mut mix);
                b.max.to_array().into_iter().for_each(&mut mix);
            }
        }
    }
    h
}

impl Bvh {
    /// Builds the hierarchy over `shapes` (deterministic: the same tree on
    /// any number of threads).
    ///
    /// # Panics
    /// With 2³¹ or more shapes (about 350 GB of primitives).
    pub fn build<S: ShapeList + ?Sized>(shapes: &S) -> Bvh {
        Self::build_with_fingerprint(shapes, fingerprint(shapes))
    }

    fn build_with_fingerprint<S: ShapeList + ?Sized>(shapes: &S, fingerprint: u64) -> Bvh {
        let n = shapes.len();
        assert!(n < TRIANGLE_BIT as usize, "a BVH holds fewer than 2^31 primitives");
        let mut refs: Vec<BuildRef> = (0..n)
            .map(|i| BuildRef {
                bounds: padded_bounds(shapes.shape(i)),
                prim: i as u32,
            })
            .collect();
        let mut pairs = Vec::with_capacity(n / 2);
        let root = if n == 0 {
            Node::new(&Aabb::EMPTY, 0, 0)
        } else {
            build_subtree(&mut refs, 0, 0, &mut pairs)
        };
        pairs.shrink_to_fit();
        let mut wide = Vec::with_capacity(pairs.len() / 2 + 1);
        if root.count > 0 {
            // A single leaf: one lane.
            let mut w = Wide::quantised(&[root]);
            w.index[0] = root.index;
            wide.push(w);
        } else if n > 0 {
            collapse(&pairs, &root, &mut wide);
        }
        // The two arrays a traversal reads, on huge pages (see `huge_pages`).
        let mut wide_on_huge_pages = vec_with_huge_pages(wide.len());
        wide_on_huge_pages.extend_from_slice(&wide);
        let wide = wide_on_huge_pages;
        let mut slots = vec_with_huge_pages(refs.len());
        slots.extend(refs.iter().map(|r| match *shapes.shape(r.prim as usize) {
            Shape::Triangle { p0, p1, p2, .. } => Slot {
                vertices: [p0, p1, p2],
                tagged: r.prim | TRIANGLE_BIT,
            },
            _ => Slot {
                vertices: [DVec3::ZERO; 3],
                tagged: r.prim,
            },
        }));
        let normals_from_vertices = (0..n).all(|i| match *shapes.shape(i) {
            Shape::Triangle { p0, p1, p2, normal } => triangle_normal(p0, p1, p2) == Some(normal),
            _ => true,
        });
        Bvh {
            root,
            pairs,
            wide,
            slots,
            fingerprint,
            normals_from_vertices,
        }
    }

    /// Number of primitives.
    pub fn len(&self) -> usize {
        self.slots.len()
    }

    pub fn is_empty(&self) -> bool {
        self.slots.is_empty()
    }

    /// Number of nodes (interior and leaves).
    pub fn node_count(&self) -> usize {
        if self.slots.is_empty() {
            0
        } else {
            1 + 2 * self.pairs.len()
        }
    }

    /// Bytes held by the hierarchy (nodes and slots with triangle copies).
    pub fn memory_bytes(&self) -> usize {
        self.pairs.capacity() * std::mem::size_of::<Pair>()
            + self.wide.capacity() * std::mem::size_of::<Wide>()
            + self.slots.capacity() * std::mem::size_of::<Slot>()
    }

    /// Depth of the deepest leaf (the root alone has depth 1).
    pub fn depth(&self) -> usize {
        fn walk(pairs: &[Pair], n: &Node) -> usize {
            if n.count > 0 {
                1
            } else {
                let [a, b] = &pairs[n.index as usize].0;
                1 + walk(pairs, a).max(walk(pairs, b))
            }
        }
        if self.slots.is_empty() {
            0
        } else {
            walk(&self.pairs, &self.root)
        }
    }

    /// The nearest hit with RAY_EPSILON_M < t < t_max and its primitive
    /// index: the linear scan's answer (smallest t; of equal t, the smallest
    /// index). `shapes` must be the list the BVH was built from.
    #[inline]
    pub fn nearest<S: ShapeList + ?Sized>(&self, shapes: &S, ray: &Ray, t_max: f64) -> Option<(Hit, usize)> {
        let o = ray.origin;
        let inv = DVec3::ONE / ray.dir;
        if self.slots.is_empty() || self.root.entry(o, inv, t_max).is_none() {
            return None;
        }
        let sheared = ShearedRay::new(ray);
        let (o, inv) = (o.to_array(), inv.to_array());
        // The best so far: t, primitive, and the normal of an analytic hit.
        let mut best_t = t_max;
        let mut best_prim = u32::MAX;
        let mut best_slot = 0usize;
        let mut best_normal = DVec3::ZERO;
        let mut stack = [Pending::default(); WIDE_STACK];
        let mut sp = 0;
        let mut next = Pending {
            index: 0,
            count: 0,
            t_enter: 0.0,
        };
        loop {
            if next.count > 0 {
                for slot in next.index as usize..(next.index + next.count) as usize {
                    let Slot { vertices, tagged } = self.slots[slot];
                    let prim = tagged & !TRIANGLE_BIT;
                    // Once there is a hit, t = best_t passes too (next_up), so
                    // an equal t can win on its smaller index.
                    let limit = if best_prim == u32::MAX {
                        best_t
                    } else {
                        best_t.next_up()
                    };
                    let hit = if tagged & TRIANGLE_BIT != 0 {
                        let [p0, p1, p2] = vertices;
                        sheared.intersect_triangle(p0, p1, p2, limit).map(|t| (t, DVec3::ZERO))
                    } else {
                        shapes
                            .shape(prim as usize)
                            .intersect(ray, limit)
                            .map(|h| (h.t, h.normal))
                    };
                    if let Some((t, normal)) = hit {
                        if t < best_t || (t == best_t && prim < best_prim) {
                            best_t = t;
                            best_prim = prim;
                            best_slot = slot;
                            best_normal = normal;
                        }
                    }
                }
            } else {
                let w = &self.wide[next.index as usize];
                let (n, hits) = w.entries(o, inv, best_t);
                self.prefetch_children(w, &hits[..n]);
                if n > 0 {
                    // The farther children are pushed farthest first; the
                    // nearest is visited now.
                    for &(t_enter, l) in hits[1..n].iter().rev() {
                        stack[sp] = Pending {
                            index: w.index[l],
                            count: w.count[l] as u32,
                            t_enter,
                        };
                        sp += 1;
                    }
                    let (t_enter, l) = hits[0];
                    next = Pending {
                        index: w.index[l],
                        count: w.count[l] as u32,
                        t_enter,
                    };
                    continue;
                }
            }
            // Pop the next subtree entered no later than the best hit.
            loop {
                if sp == 0 {
                    if best_prim == u32::MAX {
                        return None;
                    }
                    let Slot {
                        vertices: [p0, p1, p2],
                        tagged,
                    } = self.slots[best_slot];
                    let normal = if tagged & TRIANGLE_BIT == 0 {
                        best_normal
                    } else if let (true, Some(n)) = (self.normals_from_vertices, triangle_normal(p0, p1, p2)) {
                        n
                    } else {
                        match *shapes.shape(best_prim as usize) {
                            Shape::Triangle { normal, .. } => normal,
                            _ => best_normal,
                        }
                    };
                    return Some((Hit { t: best_t, normal }, best_prim as usize));
                }
                sp -= 1;
                if stack[sp].t_enter <= best_t {
                    next = stack[sp];
                    break;
                }
            }
        }
    }

    /// True when some primitive is hit with RAY_EPSILON_M < t < t_max (a
    /// shadow ray: the first hit ends the search).
    #[inline]
    pub fn occluded<S: ShapeList + ?Sized>(&self, shapes: &S, ray: &Ray, t_max: f64) -> bool {
        let o = ray.origin;
        let inv = DVec3::ONE / ray.dir;
        if self.slots.is_empty() || self.root.entry(o, inv, t_max).is_none() {
            return false;
        }
        let sheared = ShearedRay::new(ray);
        let (o, inv) = (o.to_array(), inv.to_array());
        let mut stack = [(0u32, 0u32); WIDE_STACK];
        let mut sp = 0;
        let (mut index, mut count) = (0u32, 0u32);
        loop {
            if count > 0 {
                for slot in index as usize..(index + count) as usize {
                    let Slot { vertices, tagged } = self.slots[slot];
                    let hit = if tagged & TRIANGLE_BIT != 0 {
                        let [p0, p1, p2] = vertices;
                        sheared.intersect_triangle(p0, p1, p2, t_max).is_some()
                    } else {
                        shapes.shape(tagged as usize).intersect(ray, t_max).is_some()
                    };
                    if hit {
                        return true;
                    }
                }
            } else {
                let w = &self.wide[index as usize];
                let (n, hits) = w.entries(o, inv, t_max);
                self.prefetch_children(w, &hits[..n]);
                if n > 0 {
                    for &(_, l) in hits[1..n].iter().rev() {
                        stack[sp] = (w.index[l], w.count[l] as u32);
                        sp += 1;
                    }
                    let l = hits[0].1;
                    (index, count) = (w.index[l], w.count[l] as u32);
                    continue;
                }
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            (index, count) = stack[sp];
        }
    }
}

impl Bvh {
    /// Starts loading the entered children of `w` (their wide node, or their
    /// leaf's slots) into the cache at once, so the misses of the 1 M-triangle
    /// mesh overlap instead of coming one after another.
    #[inline(always)]
    fn prefetch_children(&self, w: &Wide, entered: &[(f64, usize)]) {
        for &(_, l) in entered {
            let (index, count) = (w.index[l] as usize, w.count[l] as usize);
            if count == 0 {
                prefetch(self.wide.as_ptr().wrapping_add(index), std::mem::size_of::<Wide>());
            } else {
                prefetch(
                    self.slots.as_ptr().wrapping_add(index),
                    count * std::mem::size_of::<Slot>(),
                );
            }
        }
    }
}

/// A hint to the CPU to load `bytes` bytes from `p` into its caches; no
/// effect on results (a prefetch never faults, even past an allocation).
#[inline(always)]
fn prefetch<T>(p: *const T, bytes: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let start = p as *const i8;
        let mut offset = 0;
        while offset < bytes {
            // SAFETY: SSE is part of x86-64; a prefetch reads nothing the
            // program sees and does not fault on any address.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(start.wrapping_add(offset)) };
            offset += 64;
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (p, bytes);
}

/// A scene's BVH, built on first use and shared by every render of the
/// scene and of its clones (the study renders one scene many times).
///
/// It is reused only while the primitives' boxes and triangles are those it
/// was built from (checked by [`fingerprint`] on every use, O(n)); a scene
/// whose geometry was changed in place gets a fresh, uncached BVH.
#[derive(Clone, Default)]
pub struct BvhCache(OnceLock<Arc<Bvh>>);

impl fmt::Debug for BvhCache {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0.get() {
            Some(b) => write!(f, "BvhCache({b:?})"),
            None => f.write_str("BvhCache(not built)"),
        }
    }
}

impl BvhCache {
    /// The BVH of `shapes`: the cached one when it matches, else a new one
    /// (cached when nothing is yet).
    pub fn get_or_build<S: ShapeList + ?Sized>(&self, shapes: &S) -> Arc<Bvh> {
        let fp = fingerprint(shapes);
        let cached = self.0.get_or_init(|| Arc::new(Bvh::build_with_fingerprint(shapes, fp)));
        if cached.fingerprint == fp {
            Arc::clone(cached)
        } else {
            Arc::new(Bvh::build_with_fingerprint(shapes, fp))
        }
    }
}

mod build;
#[cfg(test)]
mod tests;

use build::build_subtree;
