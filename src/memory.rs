//! The hook that hands freed heap memory back to the operating system between stages: set
//! once by the program, called by the stages (below every stage, so they never call up into
//! the pipeline for it).

/// A function that hands the heap memory freed so far back to the operating system (with
/// glibc: `malloc_trim(0)`), set once by the program with [`set_memory_release`]. The
/// library holds no unsafe code, so it cannot call the allocator itself.
static MEMORY_RELEASE: std::sync::OnceLock<fn()> = std::sync::OnceLock::new();

/// Sets the function [`crate::quadrangulate`] calls at a few stage boundaries (after the
/// recombination's topology, before the solver of a large surface, before the optimizer,
/// before the final checks) to hand freed
/// heap memory back to the operating system. Without it, memory a stage frees may stay
/// mapped by the allocator and add to the next stages' peak: glibc keeps the free pages of
/// every thread's arena. Only the first call counts. The `blossomquad` program sets it on
/// Linux with glibc.
pub fn set_memory_release(release: fn()) {
    let _ = MEMORY_RELEASE.set(release);
}

/// Calls the function set by [`set_memory_release`], if any.
pub(crate) fn release_memory() {
    if let Some(f) = MEMORY_RELEASE.get() {
        f();
    }
}
