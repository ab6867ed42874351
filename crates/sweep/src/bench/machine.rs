//! What a benchmark ran on, recorded beside its numbers (`sweep bench --json`): timings are
//! only comparable on one machine, and the committed results say which one.

use serde::Serialize;

/// The machine, the build and the moment of a benchmark.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct Machine {
    /// `/proc/cpuinfo`'s model name.
    pub(crate) cpu: String,
    /// Cores this process may use.
    pub(crate) cores: usize,
    /// `MemTotal` of `/proc/meminfo`, GiB.
    pub(crate) memory_gib: Option<f64>,
    /// The operating system (`/etc/os-release`'s name, the kernel release).
    pub(crate) os: String,
    pub(crate) host: String,
    /// `sweep`'s version, the compiler that built it, and the commit of the working tree
    /// (with `-dirty` when it had uncommitted changes), when run from a git checkout.
    pub(crate) program: String,
    pub(crate) rustc: String,
    pub(crate) commit: Option<String>,
    /// Seconds since the Unix epoch when the benchmark started.
    pub(crate) started_unix_s: u64,
    /// The command line.
    pub(crate) command: Vec<String>,
}

fn read(path: &str) -> String {
    std::fs::read_to_string(path).unwrap_or_default()
}

fn git(args: &[&str]) -> Option<String> {
    let out = std::process::Command::new("git").args(args).output().ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

/// A benchmark file inside the repository (one that git would commit) records the commit it
/// measured; from a tree with uncommitted changes to tracked files that commit does not
/// describe the build measured, so such a file is refused before any work unless
/// `allow_dirty` (then its `commit` ends in `-dirty`, which says so).
pub(crate) fn check_clean_for(json: &std::path::Path, allow_dirty: bool) -> anyhow::Result<()> {
    if allow_dirty {
        return Ok(());
    }
    let folder = json
        .ancestors()
        .skip(1)
        .find(|a| a.as_os_str().is_empty() || a.is_dir())
        .map(|a| {
            if a.as_os_str().is_empty() {
                std::path::Path::new(".")
            } else {
                a
            }
        })
        .unwrap_or(std::path::Path::new("."));
    let in_git = |args: &[&str]| {
        std::process::Command::new("git")
            .arg("-C")
            .arg(folder)
            .args(args)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    };
    if in_git(&["rev-parse", "--is-inside-work-tree"]).as_deref() != Some("true") {
        return Ok(());
    }
    let name = json
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    // An ignored file is not committed: nothing to protect.
    if in_git(&["check-ignore", "-q", &name]).is_some() {
        return Ok(());
    }
    let dirty =
        in_git(&["status", "--porcelain", "--untracked-files=no"]).is_some_and(|s| !s.is_empty());
    anyhow::ensure!(
        !dirty,
        "--json {}: the file would be committed, but the working tree has uncommitted changes, so the commit it records would not be the build it measured; commit first (or pass --allow-dirty, and its `commit` ends in -dirty)",
        json.display()
    );
    Ok(())
}

impl Machine {
    /// Describes this machine now.
    pub(crate) fn describe() -> Machine {
        let cpuinfo = read("/proc/cpuinfo");
        let cpu = cpuinfo
            .lines()
            .find(|l| l.starts_with("model name"))
            .and_then(|l| l.split_once(':'))
            .map_or("unknown".into(), |(_, v)| v.trim().to_string());
        let memory_gib = read("/proc/meminfo")
            .lines()
            .find(|l| l.starts_with("MemTotal:"))
            .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
            .map(|kib| kib / 1048576.0);
        let os_name = read("/etc/os-release")
            .lines()
            .find_map(|l| l.strip_prefix("PRETTY_NAME="))
            .map(|v| v.trim_matches('"').to_string())
            .unwrap_or_else(|| std::env::consts::OS.into());
        let commit = git(&["rev-parse", "--short=12", "HEAD"]).map(|c| {
            let dirty = git(&["status", "--porcelain", "--untracked-files=no"])
                .is_some_and(|s| !s.is_empty());
            if dirty { format!("{c}-dirty") } else { c }
        });
        Machine {
            cpu,
            cores: std::thread::available_parallelism().map_or(1, |n| n.get()),
            memory_gib,
            os: format!(
                "{os_name}, kernel {}",
                read("/proc/sys/kernel/osrelease").trim()
            ),
            host: volphot::hostname(),
            program: format!("sweep {}", env!("CARGO_PKG_VERSION")),
            rustc: env!("VOLPHOT_RUSTC_VERSION").to_string(),
            commit,
            started_unix_s: std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs()),
            command: crate::store::recorded_command(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn describes_this_machine() {
        let m = Machine::describe();
        assert!(m.cores >= 1 && m.started_unix_s > 1_700_000_000);
        assert!(m.rustc.starts_with("rustc "), "{}", m.rustc);
        assert!(!m.os.is_empty() && !m.cpu.is_empty());
    }
}
