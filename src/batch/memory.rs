//! Allocation of the batch's per-run arrays.
//!
//! A batch of thousands of runs holds hundreds of MiB that are written once each; with 4 KiB
//! pages, the kernel's page faults and the fills before the first step took about a sixth of a
//! short `mf` job (perf, 4,096 runs of 3,000 steps). Arrays are therefore allocated zeroed (fresh
//! pages the kernel zeroes on first touch, so no fill is needed for a zero value) and, when
//! large, advised as transparent huge pages: one fault per 2 MiB instead of 512.

use ndarray::{Array, Dimension, IntoDimension};

/// Arrays smaller than this are left to ordinary pages: a huge page would not fit in them.
const HUGE_PAGE_MIN_BYTES: usize = 4 << 20;

/// A zeroed array of `shape` (every element `T::default()`, whose bits are all zero for the
/// numbers and flags the batch stores), advised as huge pages when large.
pub(super) fn zeroed<T: Copy + Default, D: Dimension>(
    shape: impl IntoDimension<Dim = D>,
) -> Array<T, D> {
    let dim = shape.into_dimension();
    // `vec![zero; n]` of a primitive zero is a zeroed allocation: no page is touched here.
    let values = vec![T::default(); dim.size()];
    advise_huge_pages(&values);
    Array::from_shape_vec(dim, values).expect("the shape's size is the vector's length")
}

/// A `shape` array of `value`, advised as huge pages when large before it is filled.
pub(super) fn filled<T: Copy + Default, D: Dimension>(
    shape: impl IntoDimension<Dim = D>,
    value: T,
) -> Array<T, D> {
    let mut array = zeroed(shape);
    array.fill(value);
    array
}

/// Asks the kernel to back `values` with transparent huge pages where it can (Linux, in `madvise`
/// mode, as this machine is). Only advice: where it is not taken, nothing changes but speed.
fn advise_huge_pages<T>(values: &[T]) {
    let bytes = std::mem::size_of_val(values);
    if bytes < HUGE_PAGE_MIN_BYTES {
        return;
    }
    #[cfg(target_os = "linux")]
    {
        const PAGE: usize = 4096;
        let start = values.as_ptr() as usize;
        let aligned = start.next_multiple_of(PAGE);
        let len = (start + bytes - aligned) / PAGE * PAGE;
        // SAFETY: the range lies inside the live allocation of `values`, page-aligned as
        // madvise requires; MADV_HUGEPAGE changes how pages are backed, never their contents.
        unsafe {
            libc::madvise(aligned as *mut libc::c_void, len, libc::MADV_HUGEPAGE);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arrays_hold_their_value_whatever_their_size() {
        let small: Array<f64, _> = filled((2, 3), 0.25);
        assert!(small.iter().all(|&v| v == 0.25));
        let large: Array<f64, _> = filled((1024, 1024), f64::NAN);
        assert_eq!(large.shape(), &[1024, 1024]);
        assert!(large.iter().all(|v| v.is_nan()));
        let flags: Array<bool, _> = zeroed((3000, 2000));
        assert!(flags.iter().all(|&f| !f));
        let minus_zero: Array<f64, _> = filled(7, -0.0);
        assert!(
            minus_zero
                .iter()
                .all(|v| v.to_bits() == (-0.0f64).to_bits())
        );
    }
}
