//! The `spherefit` binary: everything lives in the library's `cli` module.

fn main() -> std::process::ExitCode {
    spherefit::cli::run()
}
