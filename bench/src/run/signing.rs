//! `seam run --sign`: every pod signs what it publishes with its own cluster's key and checks
//! what it receives against the run's keyring (see `seam_transport::signing`), so no pod can
//! speak for another. The keys are made for the run in a private temporary folder, removed
//! when the run ends.

use std::path::PathBuf;

use seam_transport::signing::{Keyring, Signer};

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
        let mut signers = Vec::with_capacity(scene.clusters.len());
        let mut key_files = Vec::with_capacity(scene.clusters.len());
        for cluster in &scene.clusters {
            let signer = Signer::generate(ids.cluster(&cluster.name).as_u128())
                .map_err(|e| BenchError::io("make a key for", &cluster.name, e))?;
            let path = dir.join(format!("{}.key", cluster.name));
            signer
                .write_file(&path)
                .map_err(|e| BenchError::io("write", path.display(), e))?;
            signers.push(signer);
            key_files.push(path);
        }
        let keyring = dir.join("keyring");
        Keyring::of(&signers)
            .write_file(&keyring)
            .map_err(|e| BenchError::io("write", keyring.display(), e))?;
        let settings = key_files
            .iter()
            .map(|key| format!("sign_key={}&keyring={}", key.display(), keyring.display()))
            .collect();
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
