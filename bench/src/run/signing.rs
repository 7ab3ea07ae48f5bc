//! `seam run --sign`: every pod signs what it publishes with its own cluster's key and checks
//! what it receives against the run's keyring (see `seam_transport::signing`), so no pod can
//! speak for another. The keys are made for the run in a private temporary folder, removed
//! when the run ends.

use std::path::PathBuf;

use seam_transport::signing;

use crate::error::{BenchError, BenchResult};
use crate::pod::SceneIds;
use crate::scene::Scene;

/// The run's keys: one key file per pod, in scene order, and the keyring.
pub(super) struct RunKeys {
    dir: PathBuf,
    settings: Vec<String>,
}

impl RunKeys {
    /// The keys of a run of `scene` by `plan`, if it signs.
    pub(super) fn for_plan(plan: &super::RunPlan, scene: &Scene) -> BenchResult<Option<Self>> {
        if plan.sign {
            Self::make(&plan.run_id, scene).map(Some)
        } else {
            Ok(None)
        }
    }

    /// Keys for each cluster of `scene` in run `run_id`, written under a fresh folder.
    fn make(run_id: &str, scene: &Scene) -> BenchResult<Self> {
        let dir = std::env::temp_dir().join(format!("seam-keys-{run_id}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).map_err(|e| BenchError::io("create", dir.display(), e))?;
        let ids = SceneIds::new(run_id, &scene.name);
        let signers: Vec<(u128, String)> = scene
            .clusters
            .iter()
            .map(|c| (ids.cluster(&c.name).as_u128(), c.name.clone()))
            .collect();
        let settings = signing::write_keys(&dir, &signers)
            .map_err(|e| BenchError::io("write the run's keys to", dir.display(), e))?;
        Ok(Self { dir, settings })
    }

    /// `url` with pod `index`'s signing settings added.
    pub(super) fn url(&self, index: usize, url: &str) -> String {
        let joint = if url.contains('?') { '&' } else { '?' };
        format!("{url}{joint}{}", self.settings[index])
    }
}

impl Drop for RunKeys {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}
