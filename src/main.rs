//! The `blossomquad` command: everything is in the library's `cli` module.

fn main() -> std::process::ExitCode {
    blossomquad::cli::main()
}
