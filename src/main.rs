//! The `blossomquad` command: everything is in the library's `cli` module.

fn main() -> std::process::ExitCode {
    allocator::return_freed_memory();
    blossomquad::cli::main()
}

/// glibc's malloc raises its threshold for serving a block from its own mapping to the size
/// of the last such block freed (up to 32 MB), so the stages' large arrays then come from
/// the heap, and what they free stays resident: at 10^6 triangles about a quarter of the
/// peak memory was freed memory kept. A fixed threshold (the default 128 KiB, which also
/// turns the adjustment off) gives every large array its own mapping, returned when freed.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
mod allocator {
    pub(crate) fn return_freed_memory() {
        // SAFETY: mallopt only sets a tuning parameter of the allocator; it is called
        // before any other thread exists. A refusal (0) leaves the default, which is fine.
        unsafe {
            libc::mallopt(libc::M_MMAP_THRESHOLD, 128 * 1024);
        }
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
mod allocator {
    pub(crate) fn return_freed_memory() {}
}
