//! The `citypvs` command-line tool; see `citypvs --help`.

fn main() {
    std::process::exit(citypvs::cli::main());
}
