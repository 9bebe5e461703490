//! The `blossomquad` command: everything is in the library's `cli` module, except the
//! allocator settings the library (which holds no unsafe code) cannot make itself.

fn main() -> std::process::ExitCode {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    glibc::setup();
    blossomquad::cli::main()
}

/// glibc's allocator, tuned for the peak memory of one large job (see BENCHMARKS.md, issue 15).
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

    /// One arena for all threads, so that memory one thread frees serves the next
    /// allocations of every other (with an arena per thread, what a stage frees on one
    /// thread stays mapped while the next stage allocates on another); and the pipeline
    /// trims the heap between stages. A user who sets glibc's own `MALLOC_ARENA_MAX` (e.g.
    /// on a many-core machine, where threads could wait on the one arena's lock) keeps it.
    pub(super) fn setup() {
        if std::env::var_os("MALLOC_ARENA_MAX").is_none() {
            // SAFETY: called first thing in `main`, before any other thread exists;
            // mallopt only changes the allocator's own settings.
            unsafe {
                mallopt(M_ARENA_MAX, 1);
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
