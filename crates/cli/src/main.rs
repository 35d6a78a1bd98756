//! The `penumbra` command: `render` a scene, describe it (`info`), `bench`
//! the bundled scenes, or `diff` an image against a reference.

use clap::Parser;
use penumbra::args::{Cli, Command};
use penumbra::{bench, denoise, imgtool, info, merge, render_cmd};
use std::process::ExitCode;

fn main() -> ExitCode {
    penumbra::signals::ignore_file_size_limit_signal();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(a) => render_cmd::run(&a),
        Command::Info(a) => info::run(&a).map(|()| ExitCode::SUCCESS),
        Command::Bench(a) => bench::run(&a).map(|()| ExitCode::SUCCESS),
        Command::Diff(a) => imgtool::run(&a).map(|()| ExitCode::SUCCESS),
        Command::Merge(a) => merge::run(&a).map(|()| ExitCode::SUCCESS),
        Command::Denoise(a) => denoise::run(&a).map(|()| ExitCode::SUCCESS),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
