//! `seam keys`: per-cluster signing keys and the keyring that checks them (see
//! `seam_transport::signing`).

use std::path::PathBuf;

use seam_bench::error::{BenchError, BenchResult};
use seam_transport::signing;

/// `seam keys`'s flags.
#[derive(clap::Args)]
pub(crate) struct KeysArgs {
    /// Directory to write into (made if missing): `ID.key` for each cluster, readable by its
    /// owner only, and `keyring`, the public keys of them all.
    #[arg(long)]
    out: PathBuf,
    /// The clusters' ids, as seam prints them (UUIDs; dashes optional).
    #[arg(required = true)]
    clusters: Vec<String>,
}

/// Writes one key file per cluster and the keyring; prints the settings each pod's transport
/// URL takes.
pub(crate) fn main(args: &KeysArgs) -> BenchResult<()> {
    let ids = args
        .clusters
        .iter()
        .map(|text| {
            parse_id(text).ok_or_else(|| {
                BenchError::flag(
                    "CLUSTERS",
                    format!("{text:?} is not a cluster id (32 hex digits, dashes optional)"),
                )
            })
        })
        .collect::<BenchResult<Vec<u128>>>()?;
    std::fs::create_dir_all(&args.out)
        .map_err(|e| BenchError::io("create", args.out.display(), e))?;
    let signers: Vec<(u128, String)> = ids.iter().map(|id| (*id, format!("{id:032x}"))).collect();
    let settings = signing::write_keys(&args.out, &signers)
        .map_err(|e| BenchError::io("write keys to", args.out.display(), e))?;
    for ((_, name), settings) in signers.iter().zip(settings) {
        println!("{name}: {settings}");
    }
    Ok(())
}

fn parse_id(text: &str) -> Option<u128> {
    let hex: String = text.chars().filter(|c| *c != '-').collect();
    (hex.len() == 32 && hex.chars().all(|c| c.is_ascii_hexdigit()))
        .then(|| u128::from_str_radix(&hex, 16).ok())
        .flatten()
}
