//! Importing with the rejected rows listed: shared by `import` and by every subcommand that
//! reads data (`--format`, `--channel`; the names are `brdf_fit::import`'s).

use std::path::Path;

use anyhow::{Context, Result};
use brdf_fit::import::{import, Format, Pick};

/// Imports and lists the rejects and the importer's warnings on standard error.
pub fn import_reporting(path: &Path, format: Format, pick: Pick) -> Result<brdf_fit::import::Imported> {
    let imp = import(path, format, pick).with_context(|| format!("cannot import {}", path.display()))?;
    for r in &imp.rejects {
        eprintln_lossy!("{}: rejected line {}: {}", path.display(), r.line, r.reason);
    }
    for w in &imp.warnings {
        eprintln_lossy!("warning: {w}");
    }
    eprintln_lossy!(
        "{}: {} rows in, {} points out, {} rejected",
        path.display(),
        imp.rows_in,
        imp.points(),
        imp.rejects.len()
    );
    Ok(imp)
}
