//! File-system helpers: content checksums (cached), atomic writes, bounded reads of user
//! inputs, process memory.

mod checksum;
mod fsutil;
mod input;
mod memory;
mod pfm;

pub use checksum::{sha256_bytes, sha256_cached, sha256_content, sha256_file};
pub use fsutil::{hostname, is_stale_temp, temp_sibling, write_atomic, write_atomic_with};
pub(crate) use input::file_kind;
pub use input::{
    TEXT_INPUT_CAP, byte_size, confined, escaped_prefix, open_regular, read_bytes_capped,
    read_text_capped,
};
pub(crate) use memory::WORKING_BYTES_PER_VOXEL;
pub use memory::{memory_budget_bytes, peak_memory_bytes, process_cpu_seconds};
pub(crate) use pfm::read_pfm_bounded;
pub use pfm::{PfmChannels, read_pfm, write_pfm};
