//! `keycomp`: key-component detection, description and partial retrieval for 3D meshes, after
//! I. Sipiran and B. Bustos, "Key-components: detection of salient regions on 3D meshes",
//! The Visual Computer 29, 2013.
//!
//! Subcommands are verbs; `--json` gives machine-readable output on stdout. Exit codes: 0 ok,
//! 1 no result, 2 error (bad input, bad arguments). A closed stdout pipe exits 0.

mod args;
mod bench;
mod colors;
mod commands;
mod output;
mod progress;
mod report;
mod serve;

use commands::{
    demo, detect, index, keypoints, r#match, query, render, serve as serve_cmd, surface, transform,
};

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Key-components of 3D meshes: detect salient regions, index shapes, query by example.
#[derive(Debug, Parser)]
#[command(
    name = "keycomp",
    version,
    about = "Key-component detection, description and partial retrieval for 3D meshes (Sipiran & Bustos 2013)",
    long_about = None
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Harris 3D keypoints of a mesh (Sipiran & Bustos 2011), best first.
    #[command(after_help = keypoints::EXAMPLES)]
    Keypoints(keypoints::Args),
    /// Key-components of a mesh (Sipiran & Bustos 2013): Harris 3D, geodesics, SMACOF,
    /// adaptive clustering, region growing.
    #[command(after_help = detect::EXAMPLES)]
    Detect(detect::Args),
    /// Apply a SHREC'10-style transformation to a null mesh and write the transformed mesh and
    /// its vertex correspondence.
    #[command(after_help = transform::EXAMPLES)]
    Transform(transform::Args),
    /// Build and inspect the on-disk index of described shapes.
    #[command(subcommand)]
    Index(index::IndexCommand),
    /// Rank the indexed shapes against a query mesh (whole shape or fragment).
    #[command(after_help = query::EXAMPLES)]
    Query(query::Args),
    /// A local web app and HTTP JSON API over an index: browse the collection, search by
    /// example (drop a mesh, scan or point cloud), see matched parts in 3D.
    #[command(after_help = serve_cmd::EXAMPLES)]
    Serve(serve_cmd::Args),
    /// Render a shaded PNG of a mesh, with key-components, response or keypoints coloured.
    #[command(after_help = render::EXAMPLES)]
    Render(render::Args),
    /// Write the canonical surface keycomp analyses instead of the file: one connected
    /// surface of a fixed density, from a mesh, a triangle soup, a range scan or a point cloud.
    #[command(after_help = surface::EXAMPLES)]
    Surface(surface::Args),
    /// Match two meshes part to part: key-components paired by descriptor, checked for layout and size.
    #[command(name = "match", after_help = r#match::EXAMPLES)]
    Match(r#match::Args),
    /// Benchmarks that produce the tables in BENCHMARKS.md.
    #[command(subcommand)]
    Bench(bench::BenchCommand),
    /// The built-in demo: generate a collection of shapes in code, index it, query it with
    /// held-out shapes and fragments, print a table and write an HTML report (no files needed).
    #[command(after_help = demo::EXAMPLES)]
    Demo(demo::Args),
}

/// Parses the command line. Negative numbers are taken as values everywhere (no option name
/// starts with a digit), so `-k -1` gets the option's own message ("expected a whole number of
/// at least 1") instead of clap's advice to write `-- -1`.
fn parse_cli() -> Cli {
    fn allow_negatives(cmd: clap::Command) -> clap::Command {
        cmd.allow_negative_numbers(true)
            .mut_subcommands(allow_negatives)
    }
    let cmd = allow_negatives(<Cli as clap::CommandFactory>::command());
    let matches = cmd.get_matches();
    match <Cli as clap::FromArgMatches>::from_arg_matches(&matches) {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    }
}

fn main() -> ExitCode {
    // clap exits 2 on bad arguments by itself
    let cli = parse_cli();
    let result = match cli.command {
        Command::Keypoints(args) => keypoints::run(args),
        Command::Detect(args) => detect::run(args),
        Command::Demo(args) => demo::run(args),
        Command::Transform(args) => transform::run(args),
        Command::Match(args) => r#match::run(args),
        Command::Index(cmd) => index::run(cmd),
        Command::Query(args) => query::run(args),
        Command::Render(args) => render::run(args),
        Command::Serve(args) => serve_cmd::run(args),
        Command::Surface(args) => surface::run(args),
        Command::Bench(cmd) => bench::run(cmd),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            if output::is_broken_pipe(&e) {
                return ExitCode::SUCCESS;
            }
            eprintln!("error: {}", output::error_chain(&e));
            ExitCode::from(2)
        }
    }
}
