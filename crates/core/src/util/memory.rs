//! Process memory: the peak resident set (recorded with every render) and the budget that
//! volume loading refuses to exceed.

/// Peak resident set size of this process (Linux `VmHWM`), if available.
pub fn peak_memory_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Working memory a loaded volume needs per voxel, in bytes: its `f32` grid and the
/// medium's transferred copy (4 + 4), the exact optical depth's compact copy (up to 2, and
/// 1 more while a byte-indexed one is built) and the empty-cell bits (1/8), rounded up.
pub(crate) const WORKING_BYTES_PER_VOXEL: u64 = 12;

/// Largest volume, in bytes of working memory (12 per voxel: both `f32` grids, the compact
/// copy and the empty-cell bits), that we agree to load: half the machine's available
/// memory.
pub fn memory_budget_bytes() -> u64 {
    let available = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|text| {
            text.lines()
                .find(|l| l.starts_with("MemAvailable:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<u64>().ok())
                .map(|kb| kb * 1024)
        })
        .unwrap_or(8 << 30);
    available / 2
}

/// CPU seconds (user + system) used by this process so far, all threads, when the OS
/// reports them (`/proc/self/stat`, in clock ticks of 1/100 s): the cost measure of
/// efficiency comparisons, which wall time on a shared machine is not.
pub fn process_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name (which may hold spaces): utime and
    // stime are the 14th and 15th fields of the line, the 12th and 13th after it.
    let rest = &stat[stat.rfind(')')? + 1..];
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| fields.get(i)?.parse::<u64>().ok();
    Some((ticks(11)? + ticks(12)?) as f64 / 100.0)
}

#[cfg(test)]
mod tests {
    #[test]
    fn cpu_seconds_grow_with_work() {
        let Some(before) = super::process_cpu_seconds() else {
            crate::test_util::skip("cpu_seconds_grow_with_work", "no /proc/self/stat here");
            return;
        };
        // A fixed amount of work (not a wall-clock time: other processes may share the
        // cores), about 0.3 CPU-seconds on a 2020s core.
        let mut x = 0u64;
        for _ in 0..300_000_000u64 {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(std::hint::black_box(1));
        }
        std::hint::black_box(x);
        let after = super::process_cpu_seconds().unwrap();
        assert!(after - before >= 0.05, "{before} → {after}");
    }
}
