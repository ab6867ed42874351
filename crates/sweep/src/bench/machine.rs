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
