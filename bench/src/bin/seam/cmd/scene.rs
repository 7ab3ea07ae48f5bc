//! `seam scene`: scene files checked and summarised.

use std::path::PathBuf;

use seam_bench::error::BenchResult;

/// `seam scene`'s flags.
#[derive(clap::Args)]
pub(crate) struct SceneArgs {
    /// Scene files (TOML).
    #[arg(required = true)]
    files: Vec<PathBuf>,
}

/// One line per file; the first bad file is the error.
pub(crate) fn main(args: &SceneArgs) -> BenchResult<()> {
    for file in &args.files {
        let scene = seam_bench::scene::load(file)?;
        let entities: u64 = scene.entities.iter().map(|e| e.copies()).sum();
        println!(
            "{}: scene {:?}: {} clusters, {entities} entities, {} events, {} ticks of {:.4} s",
            file.display(),
            scene.name,
            scene.clusters.len(),
            scene.events.len(),
            scene.ticks,
            scene.dt
        );
    }
    Ok(())
}
