//! What a benchmark ran on: processor, cores, memory, operating system, compiler and
//! commit, so a committed JSON says whose numbers it holds.

use std::path::Path;
use std::process::Command;

use serde::Serialize;

/// The machine and build a benchmark ran on (`unknown` where a fact is not available).
#[derive(Debug, Clone, Serialize)]
pub(crate) struct Machine {
    pub(crate) cpu: String,
    /// Logical processors the process may use.
    pub(crate) cores: usize,
    pub(crate) memory_gib: Option<f64>,
    pub(crate) os: String,
    /// The compiler that built this binary.
    pub(crate) rustc: String,
    /// The checkout's commit (`+dirty` with uncommitted changes), where run.
    pub(crate) commit: String,
    pub(crate) hostname: String,
}

impl Machine {
    /// Describes this machine and build.
    pub(crate) fn describe() -> Self {
        Machine {
            cpu: cpu_model().unwrap_or_else(unknown),
            cores: std::thread::available_parallelism().map_or(0, |n| n.get()),
            memory_gib: memory_gib(),
            os: os().unwrap_or_else(unknown),
            rustc: env!("VOLPHOT_RUSTC_VERSION").to_string(),
            commit: commit(Path::new(".")).unwrap_or_else(unknown),
            hostname: volphot::hostname(),
        }
    }
}

fn unknown() -> String {
    "unknown".into()
}

/// The first `model name` of `/proc/cpuinfo`.
fn cpu_model() -> Option<String> {
    let text = std::fs::read_to_string("/proc/cpuinfo").ok()?;
    text.lines()
        .find(|l| l.starts_with("model name"))
        .and_then(|l| l.split_once(':'))
        .map(|(_, v)| v.trim().to_string())
}

/// `MemTotal` of `/proc/meminfo`.
fn memory_gib() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let kib: f64 = text
        .lines()
        .find(|l| l.starts_with("MemTotal:"))?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()?;
    Some((kib / 1024.0 / 1024.0 * 10.0).round() / 10.0)
}

/// `PRETTY_NAME` of `/etc/os-release` and the kernel's release.
fn os() -> Option<String> {
    let release = std::fs::read_to_string("/etc/os-release").ok();
    let name = release.as_deref().and_then(|t| {
        t.lines()
            .find_map(|l| l.strip_prefix("PRETTY_NAME="))
            .map(|v| v.trim_matches('"').to_string())
    });
    let kernel = std::fs::read_to_string("/proc/sys/kernel/osrelease")
        .ok()
        .map(|k| format!("Linux {}", k.trim()));
    match (name, kernel) {
        (Some(n), Some(k)) => Some(format!("{n}, {k}")),
        (n, k) => n.or(k).or_else(|| Some(std::env::consts::OS.to_string())),
    }
}

/// `git rev-parse HEAD` in `dir`, with `+dirty` when tracked files differ from it.
fn commit(dir: &Path) -> Option<String> {
    let git = |args: &[&str]| {
        Command::new("git")
            .arg("-C")
            .arg(dir)
            .args(args)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    };
    let head = git(&["rev-parse", "HEAD"])?;
    let dirty =
        git(&["status", "--porcelain", "--untracked-files=no"]).is_some_and(|s| !s.is_empty());
    Some(if dirty { format!("{head}+dirty") } else { head })
}
