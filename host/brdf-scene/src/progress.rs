//! A progress bar for a person watching a terminal (hidden when output is piped), shared by
//! the scene subcommands.

use std::io::IsTerminal;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// A bar of `len` steps labelled `unit` on standard error, or a hidden one unless both
/// standard output and standard error are terminals.
pub fn terminal_bar(len: usize, unit: &str) -> ProgressBar {
    let watched = std::io::stderr().is_terminal() && std::io::stdout().is_terminal();
    let bar = if watched && len > 1 {
        ProgressBar::with_draw_target(Some(len as u64), ProgressDrawTarget::stderr())
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template(&format!(
            "{{bar:40}} {{pos}}/{{len}} {unit}, {{elapsed}} elapsed, eta {{eta}}"
        ))
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
}
