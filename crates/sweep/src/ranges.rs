//! Lists of cell indices written compactly (`0-3,7,9-10`): what a Slurm array takes and
//! what reports and `sweep status` print. A leaf, so that the backends, the render loop and
//! the report share it without importing each other.

/// `0-3,7,9-10` for a sorted list of indices.
pub(crate) fn compress_ranges(v: &[usize]) -> String {
    let mut parts = Vec::new();
    let mut i = 0;
    while i < v.len() {
        let start = v[i];
        let mut end = start;
        while i + 1 < v.len() && v[i + 1] == end + 1 {
            i += 1;
            end = v[i];
        }
        parts.push(if start == end {
            format!("{start}")
        } else {
            format!("{start}-{end}")
        });
        i += 1;
    }
    parts.join(",")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_compress() {
        assert_eq!(compress_ranges(&[0, 1, 2, 5, 7, 8]), "0-2,5,7-8");
        assert_eq!(compress_ranges(&[]), "");
        assert_eq!(compress_ranges(&[4]), "4");
        assert_eq!(compress_ranges(&[3, 4, 6]), "3-4,6");
    }
}
