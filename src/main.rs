//! The spherestep binary: parses the command line (`cli`), runs the command and prints any
//! error, the one place errors are printed.

mod cli;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = cli::Cli::parse();
    let stdout = std::io::stdout();
    match cli.run(&mut stdout.lock()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // what files and devices hold is in the message: never sent to the terminal raw
            let message = spherestep::text::printable_lines(&format!("{e:#}"));
            eprintln!("spherestep: error: {message}");
            ExitCode::FAILURE
        }
    }
}
