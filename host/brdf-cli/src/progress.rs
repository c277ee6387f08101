//! The one progress bar of the command line: on standard error when it is a terminal
//! (whatever standard output is: a bar helps most while the results go to a file), for more
//! than one step; hidden otherwise, so piped and logged runs stay clean. The libraries report
//! progress through a callback and draw nothing.

use std::io::IsTerminal;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// A bar of `len` steps, each one `unit` (`datasets`, `aspects`).
pub fn bar(len: usize, unit: &str) -> ProgressBar {
    let bar = if len > 1 && std::io::stderr().is_terminal() {
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
