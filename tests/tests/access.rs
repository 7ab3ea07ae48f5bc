//! Access: the shared memory and files a pod's iceoryx2 transport creates are its user's only.
//!
//! Every file under this test's prefix in `/dev/shm` and in iceoryx2's root directory must have
//! no group or other permission bits, with one exception iceoryx2 makes by design: the 16-byte
//! global management segment (`*.global_mgmt`, a node-id counter) is read-write for everyone.
//! docs/operations.md ("Access") says what that leaves a co-hosted process of another user.

use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};

use seam_tests::{PATIENCE, TestContext, publish_until_received};
use seam_transport::Backend;

/// Files under `dir` (recursively) whose name starts with `prefix`, with their mode.
fn files_with_prefix(dir: &Path, prefix: &str, found: &mut Vec<(PathBuf, u32)>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        let Ok(meta) = std::fs::symlink_metadata(&path) else {
            continue;
        };
        if meta.is_dir() {
            files_with_prefix(&path, prefix, found);
        } else if entry.file_name().to_string_lossy().starts_with(prefix) {
            found.push((path, meta.permissions().mode() & 0o777));
        }
    }
}

#[test]
fn shared_memory_and_iceoryx2_files_are_the_owners_only() {
    let Some(ctx) = TestContext::new(Backend::Shm) else {
        return;
    };
    let prefix = ctx.prefix().expect("an shm prefix");
    let mut publisher = ctx.open();
    let mut subscriber = ctx.open();
    let channel = ctx.channel("access");
    subscriber.subscribe(&channel).expect("subscribe");
    publish_until_received(
        publisher.as_mut(),
        subscriber.as_mut(),
        &channel,
        b"private",
        PATIENCE,
    );

    let root = iceoryx2::config::Config::default()
        .global
        .root_path()
        .to_string();
    let mut found = Vec::new();
    files_with_prefix(Path::new("/dev/shm"), &prefix, &mut found);
    files_with_prefix(Path::new(&root), &prefix, &mut found);
    let shared_memory = found
        .iter()
        .filter(|(p, _)| p.starts_with("/dev/shm"))
        .count();
    assert!(
        shared_memory >= 2 && found.len() > shared_memory,
        "the transport made shared memory and iceoryx2 files: {found:?}"
    );
    for (path, mode) in &found {
        let name = path.to_string_lossy();
        if name.ends_with(".global_mgmt") {
            continue;
        }
        assert_eq!(
            mode & 0o077,
            0,
            "{name} is open to group or others (mode {mode:o})"
        );
    }
}
