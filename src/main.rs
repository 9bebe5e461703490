//! The `blossomquad` command: everything is in the library's `cli` module, except the
//! allocator settings the library (which holds no unsafe code) cannot make itself.

fn main() -> std::process::ExitCode {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    glibc::setup();
    blossomquad::cli::main()
}

/// glibc's allocator, tuned for the peak memory of one large job (figures in BENCHMARKS.md,
/// "Measurements behind the defaults", Memory).
#[cfg(all(target_os = "linux", target_env = "gnu"))]
mod glibc {
    use std::ffi::c_int;

    extern "C" {
        /// Sets an allocator parameter; returns 1 on success.
        fn mallopt(param: c_int, value: c_int) -> c_int;
        /// Releases free heap memory to the system, keeping `pad` bytes; returns 1 if
        /// memory was released.
        fn malloc_trim(pad: usize) -> c_int;
    }

    /// `M_ARENA_MAX` of glibc's `malloc.h`.
    const M_ARENA_MAX: c_int = -8;
    /// `M_MMAP_THRESHOLD` of glibc's `malloc.h`.
    const M_MMAP_THRESHOLD: c_int = -3;
    /// Allocations from this size on get their own mapping.
    const MMAP_THRESHOLD: c_int = 1 << 20;

    /// One arena for all threads, so that memory one thread frees serves the next
    /// allocations of every other (with an arena per thread, what a stage frees on one
    /// thread stays mapped while the next stage allocates on another); and the pipeline
    /// trims the heap between stages. And a fixed threshold of 1 MiB above which an
    /// allocation gets its own mapping: glibc's default threshold grows to the size of the
    /// largest such block freed, after which the stages' large arrays come from the heap,
    /// whose freed pages stay resident until the next trim. A user who sets glibc's own
    /// `MALLOC_ARENA_MAX` (e.g. on a many-core machine, where threads could wait on the one
    /// arena's lock) or `MALLOC_MMAP_THRESHOLD_` keeps it.
    pub(super) fn setup() {
        let unset = |name: &str| std::env::var_os(name).is_none();
        // SAFETY (both calls): called first thing in `main`, before any other thread
        // exists; mallopt only changes the allocator's own settings.
        if unset("MALLOC_ARENA_MAX") {
            unsafe {
                mallopt(M_ARENA_MAX, 1);
            }
        }
        if unset("MALLOC_MMAP_THRESHOLD_") {
            unsafe {
                mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD);
            }
        }
        blossomquad::set_memory_release(trim);
    }

    /// Hands the heap's free pages back to the system (the pipeline calls it between
    /// stages, so memory one stage freed does not stay resident through the next).
    fn trim() {
        // SAFETY: malloc_trim takes no pointer and only changes the allocator's own state,
        // under its own locks; any thread may call it at any time.
        unsafe {
            malloc_trim(0);
        }
    }
}
