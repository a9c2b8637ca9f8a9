//! `stewart`: the command-line tool. All the work lives in the `stewart-cli` crate; this thin
//! binary exists so that `cargo run simulate` works from the workspace root.

fn main() -> std::process::ExitCode {
    stewart_cli::main_entry()
}
