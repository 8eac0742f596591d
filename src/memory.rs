//! Bytes held on the heap, for the memory report by part (`Simulation::memory_by_part`).

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
