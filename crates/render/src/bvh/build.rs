//! Building the BVH: binned surface-area-heuristic splits (see the module
//! doc of [`super`]), subtrees built in parallel above
//! [`PARALLEL_BUILD_MIN`] primitives.

use super::*;

/// How a node is split.
pub(super) enum Split {
    Leaf,
    /// Centroid bin (of [`BINS`] over `[lo, lo + BINS/scale)`) on `axis` ≤ `bin` goes left.
    Bin {
        axis: usize,
        lo: f64,
        scale: f64,
        bin: usize,
    },
    /// The first half by position (all centroids equal, or too deep).
    Middle,
}

/// The centroid bin of a box along an axis.
#[inline(always)]
pub(super) fn bin_of(b: &Aabb, axis: usize, lo: f64, scale: f64) -> usize {
    let c = (b.min[axis] + b.max[axis]) * 0.5;
    (((c - lo) * scale) as usize).min(BINS - 1)
}

/// Builds the subtree over `refs` (slots `first_slot..`) at `depth`: returns
/// its root node and appends the pairs below it to `pairs`, depth first.
pub(super) fn build_subtree(refs: &mut [BuildRef], first_slot: u32, depth: usize, pairs: &mut Vec<Pair>) -> Node {
    let n = refs.len();
    let mut bounds = Aabb::EMPTY;
    let mut centroids = Aabb::EMPTY;
    for r in refs.iter() {
        bounds = bounds.union(r.bounds);
        centroids = centroids.union_point(r.bounds.centroid());
    }
    let mid = match choose_split(refs, &bounds, &centroids, depth) {
        Split::Leaf => return Node::new(&bounds, first_slot, n as u32),
        Split::Middle => {
            if depth >= MAX_SAH_DEPTH {
                // Object median on the widest centroid axis keeps the halves compact.
                let axis = (centroids.max - centroids.min).max_position();
                refs.select_nth_unstable_by(n / 2, |a, b| {
                    a.bounds.centroid()[axis]
                        .total_cmp(&b.bounds.centroid()[axis])
                        .then(a.prim.cmp(&b.prim))
                });
            }
            n / 2
        }
        Split::Bin { axis, lo, scale, bin } => partition(refs, |r| bin_of(&r.bounds, axis, lo, scale) <= bin),
    };
    let (left, right) = refs.split_at_mut(mid);
    let right_slot = first_slot + mid as u32;
    let me = pairs.len();
    pairs.push(Pair::default());
    let children = if n >= PARALLEL_BUILD_MIN {
        // Each half into its own list (pair indices from 0), appended in the
        // sequential order: the same tree on any number of threads.
        let ((a, pa), (b, pb)) = rayon::join(
            || {
                let mut v = Vec::new();
                (build_subtree(left, first_slot, depth + 1, &mut v), v)
            },
            || {
                let mut v = Vec::new();
                (build_subtree(right, right_slot, depth + 1, &mut v), v)
            },
        );
        [append_shifted(pairs, a, pa), append_shifted(pairs, b, pb)]
    } else {
        let a = build_subtree(left, first_slot, depth + 1, pairs);
        let b = build_subtree(right, right_slot, depth + 1, pairs);
        [a, b]
    };
    pairs[me] = Pair(children);
    Node::new(&bounds, me as u32, 0)
}

/// Appends the pairs of a subtree built on its own (pair indices from 0),
/// shifting the interior nodes' pair indices (and its root's) to their new place.
pub(super) fn append_shifted(pairs: &mut Vec<Pair>, mut root: Node, sub: Vec<Pair>) -> Node {
    let base = pairs.len() as u32;
    let shift = |n: &mut Node| {
        if n.count == 0 {
            n.index += base;
        }
    };
    shift(&mut root);
    pairs.extend(sub.into_iter().map(|mut p| {
        p.0.iter_mut().for_each(shift);
        p
    }));
    root
}

/// Moves the refs for which `left` holds to the front (stable order is not
/// needed, only determinism); returns how many there are.
pub(super) fn partition(refs: &mut [BuildRef], left: impl Fn(&BuildRef) -> bool) -> usize {
    let mut i = 0;
    let mut j = refs.len();
    while i < j {
        if left(&refs[i]) {
            i += 1;
        } else {
            j -= 1;
            refs.swap(i, j);
        }
    }
    i
}

/// The binned-SAH decision for one node (Wald 2007).
pub(super) fn choose_split(refs: &[BuildRef], bounds: &Aabb, centroids: &Aabb, depth: usize) -> Split {
    let n = refs.len();
    if n == 1 {
        return Split::Leaf;
    }
    if depth >= MAX_SAH_DEPTH {
        return Split::Middle;
    }
    let extent = centroids.max - centroids.min;
    #[derive(Clone, Copy)]
    struct Bin {
        bounds: Aabb,
        count: usize,
    }
    let empty = Bin {
        bounds: Aabb::EMPTY,
        count: 0,
    };
    let mut bins = [[empty; BINS]; 3];
    let mut scale = [0.0; 3];
    for axis in 0..3 {
        if extent[axis] > 0.0 {
            scale[axis] = BINS as f64 / extent[axis];
        }
    }
    if scale == [0.0; 3] {
        // Every centroid is the same point: nothing to sort by.
        return if n <= MAX_LEAF { Split::Leaf } else { Split::Middle };
    }
    let lo = centroids.min;
    for r in refs {
        for axis in 0..3 {
            if scale[axis] > 0.0 {
                let b = &mut bins[axis][bin_of(&r.bounds, axis, lo[axis], scale[axis])];
                b.bounds = b.bounds.union(r.bounds);
                b.count += 1;
            }
        }
    }
    // Sweep: cost of splitting after bin i = A_L·N_L + A_R·N_R.
    let mut best: Option<(f64, usize, usize)> = None;
    for axis in 0..3 {
        if scale[axis] == 0.0 {
            continue;
        }
        let bins = &bins[axis];
        let mut right_area = [0.0; BINS];
        let mut acc = Aabb::EMPTY;
        let mut right_count = [0usize; BINS];
        let mut count = 0;
        for i in (1..BINS).rev() {
            acc = acc.union(bins[i].bounds);
            count += bins[i].count;
            right_area[i] = acc.half_area();
            right_count[i] = count;
        }
        let mut acc = Aabb::EMPTY;
        let mut count = 0;
        for i in 0..BINS - 1 {
            acc = acc.union(bins[i].bounds);
            count += bins[i].count;
            if count == 0 || right_count[i + 1] == 0 {
                continue;
            }
            let cost = acc.half_area() * count as f64 + right_area[i + 1] * right_count[i + 1] as f64;
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, i));
            }
        }
    }
    let Some((cost, axis, bin)) = best else {
        return if n <= MAX_LEAF { Split::Leaf } else { Split::Middle };
    };
    let split_cost = TRAVERSAL_COST + cost / bounds.half_area();
    if n <= MAX_LEAF && n as f64 <= split_cost {
        return Split::Leaf;
    }
    Split::Bin {
        axis,
        lo: lo[axis],
        scale: scale[axis],
        bin,
    }
}
