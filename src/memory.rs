//! Bytes held on the heap, for the memory report by part (`Simulation::memory_by_part`), and
//! how the programs have the allocator give large blocks back.

/// Bytes a value holds on the heap (what it reserved, whether used or not).
pub(crate) trait HeapBytes {
    fn heap_bytes(&self) -> usize;
}

impl<T> HeapBytes for Vec<T> {
    /// Its capacity's elements; not what they hold on the heap in turn.
    fn heap_bytes(&self) -> usize {
        self.capacity() * std::mem::size_of::<T>()
    }
}

/// Have the system allocator give blocks of 4 MiB and more back to the system as soon as they
/// are freed (glibc's `M_MMAP_THRESHOLD`). By default glibc raises that threshold to the
/// largest block freed so far, up to 32 MiB, and a million-grain run's vectors of some 24 MB
/// then come from the heap, where the freed ones stay resident among other blocks: 142 MiB of
/// its peak (docs/performance.md, "The values and the contacts held once"). Smaller blocks
/// come from the heap: a vector over the unknowns reaches 4 MiB at some 170,000 grains, and
/// `make run`'s 1,000-grain test takes the same time. For the programs: a library does not
/// set its host process's allocator.
pub fn give_back_large_blocks() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `mallopt` only sets a parameter of the allocator; called before any thread.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 4 << 20);
    }
}
