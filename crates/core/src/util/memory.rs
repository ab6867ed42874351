//! Process memory: the peak resident set (recorded with every render) and the budget that
//! volume loading refuses to exceed.

/// Peak resident set size of this process (Linux `VmHWM`), if available.
pub fn peak_memory_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Largest volume, in bytes of `f32` working memory, that we agree to load. Half the
/// machine's available memory (the medium keeps a second grid of the same size).
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
