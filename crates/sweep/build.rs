//! Records the compiler's version for `sweep bench --reference --json` (what built the
//! binary whose times it reports).

fn main() {
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let version = std::process::Command::new(rustc)
        .arg("--version")
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_else(|| "unknown".into());
    println!("cargo:rustc-env=VOLPHOT_RUSTC_VERSION={version}");
    println!("cargo:rerun-if-changed=build.rs");
}
