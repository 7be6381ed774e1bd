//! End-to-end tests: the host against a simulated fleet over loopback sockets.
//!
//! The tests live in `tests/`; this library holds what they share.

use std::path::PathBuf;

/// A fresh scratch folder under the system temp dir (run folders, config files).
pub fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "puzzlebot-e2e-{name}-{}-{}",
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_nanos())
            .unwrap_or(0)
    ));
    std::fs::create_dir_all(&d).expect("scratch folder");
    d
}
