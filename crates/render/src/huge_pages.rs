//! Large arrays backed by 2 MiB pages, for the BVH of a big mesh.
//!
//! Why: a random ray through the BVH of a 1 M-triangle mesh touches a few
//! dozen places scattered over ~90 MB of nodes and leaf slots. With the
//! default 4 KiB pages that is ~23 000 pages, far more than the CPU's TLB
//! holds, so nearly every such access also pays a page-table walk. Asking
//! Linux for transparent huge pages (`madvise(MADV_HUGEPAGE)`, which this
//! machine's kernel honours in its default `madvise` mode) cuts the pages to
//! ~45. Embree asks for huge pages for the same reason.
//!
//! How: [`vec_with_huge_pages`] reserves the vector's capacity and advises
//! the kernel before any element is written, so the page faults that follow
//! allocate huge pages directly. Only arrays of at least [`MIN_BYTES`] are
//! advised. The advice changes speed only: on another OS, with THP off, or
//! when the call fails, the vector is an ordinary one.

/// Arrays smaller than one huge page gain nothing.
pub const MIN_BYTES: usize = 2 << 20;

/// An empty vector with room for `capacity` elements, whose memory the
/// kernel is asked to back with transparent huge pages (see the module doc).
pub fn vec_with_huge_pages<T>(capacity: usize) -> Vec<T> {
    let v: Vec<T> = Vec::with_capacity(capacity);
    let bytes = capacity.saturating_mul(std::mem::size_of::<T>());
    if bytes >= MIN_BYTES {
        advise_huge_pages(v.as_ptr() as usize, bytes);
    }
    v
}

#[cfg(target_os = "linux")]
fn advise_huge_pages(start: usize, bytes: usize) {
    const PAGE: usize = 4096;
    // madvise wants a page-aligned start; the huge pages then go to the
    // 2 MiB-aligned stretches inside the range.
    let first = start.next_multiple_of(PAGE);
    let end = (start + bytes) / PAGE * PAGE;
    if end <= first {
        return;
    }
    // SAFETY: the range lies inside the vector's own allocation (rounded
    // inward to whole pages); MADV_HUGEPAGE changes how its pages are backed,
    // never their contents, and its failure is harmless (ignored).
    let _ = unsafe { libc::madvise(first as *mut libc::c_void, end - first, libc::MADV_HUGEPAGE) };
}

#[cfg(not(target_os = "linux"))]
fn advise_huge_pages(_start: usize, _bytes: usize) {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_advised_vector_is_an_ordinary_vector() {
        let mut v = vec_with_huge_pages::<u64>(1 << 20);
        assert!(v.capacity() >= 1 << 20);
        v.extend(0..1 << 20);
        assert_eq!(v.iter().sum::<u64>(), ((1u64 << 20) - 1) * (1 << 20) / 2);
        let small = vec_with_huge_pages::<u8>(10);
        assert!(small.is_empty());
    }
}
