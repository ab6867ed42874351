//! Patient geometry shared by the DICOM and NIfTI readers: the direction of each voxel
//! axis in the patient frame (LPS: +x left, +y posterior, +z superior), the test for an
//! axis-aligned orientation, and the permutation and flips that bring such a volume onto
//! the grid axes (grid x = L, y = P, z = S).

use serde::{Deserialize, Serialize};

/// How far a direction cosine may be from 0 or ±1 and still count as axis-aligned.
const AXIS_TOLERANCE: f64 = 1e-4;

const AXIS_NAMES: [[&str; 2]; 3] = [["L", "R"], ["P", "A"], ["S", "I"]];

/// The voxel axes of a volume in the patient frame (LPS, millimetres).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PatientAxes {
    /// Unit direction of voxel axes i, j, k (index fastest to slowest) in LPS.
    pub directions: [[f64; 3]; 3],
    /// Voxel spacing along i, j, k in mm.
    pub spacing: [f64; 3],
}

/// For each grid axis: which voxel axis feeds it and whether it runs backwards.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AxisMap {
    /// Source voxel axis of grid axes x, y, z.
    pub source: [usize; 3],
    /// Whether the source axis is read backwards.
    pub flip: [bool; 3],
}

impl AxisMap {
    /// No permutation, no flips.
    pub const IDENTITY: AxisMap = AxisMap {
        source: [0, 1, 2],
        flip: [false; 3],
    };
}

/// How the voxels were oriented onto the grid: recorded in every output.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum Orientation {
    /// Axis-aligned: permuted and flipped exactly so the grid axes are L, P, S.
    AxisAligned {
        /// The file's voxel axes i, j, k as patient directions, e.g. `["L", "P", "S"]` or
        /// `["R", "A", "S"]` (NIfTI's usual RAS).
        file_axes: [String; 3],
    },
    /// Oblique: rendered in the volume's own frame (grid x, y, z = voxel axes i, j, k),
    /// not in patient axes.
    Oblique {
        /// Direction cosines of voxel axes i, j, k in LPS.
        directions: [[f64; 3]; 3],
    },
}

impl Orientation {
    /// One line for captions and logs.
    pub fn describe(&self) -> String {
        match self {
            Orientation::AxisAligned { file_axes } => format!(
                "axis-aligned, file axes {}, shown as grid x=L y=P z=S",
                file_axes.join("")
            ),
            Orientation::Oblique { directions } => format!(
                "OBLIQUE (axes {directions:?} in LPS): rendered in the volume's own frame, not in patient axes"
            ),
        }
    }
}

impl PatientAxes {
    /// The axis map onto grid L, P, S and its description, or the volume's own frame for
    /// oblique axes.
    pub fn grid_map(&self) -> (AxisMap, Orientation) {
        let mut source = [usize::MAX; 3];
        let mut flip = [false; 3];
        let mut names: [String; 3] = Default::default();
        for (s, d) in self.directions.iter().enumerate() {
            let Some(a) = (0..3).find(|&a| (d[a].abs() - 1.0).abs() < AXIS_TOLERANCE) else {
                return self.oblique();
            };
            if source[a] != usize::MAX {
                return self.oblique();
            }
            source[a] = s;
            flip[a] = d[a] < 0.0;
            names[s] = AXIS_NAMES[a][usize::from(flip[a])].to_string();
        }
        (
            AxisMap { source, flip },
            Orientation::AxisAligned { file_axes: names },
        )
    }

    fn oblique(&self) -> (AxisMap, Orientation) {
        (
            AxisMap::IDENTITY,
            Orientation::Oblique {
                directions: self.directions,
            },
        )
    }

    /// Spacing along grid x, y, z after `map`.
    pub fn grid_spacing(&self, map: &AxisMap) -> [f64; 3] {
        map.source.map(|s| self.spacing[s])
    }
}

/// Reorders x-fastest `values` of `dims` (voxel axes i, j, k) onto the grid axes of `map`;
/// returns the values and the grid dims. The identity map returns the input untouched.
pub fn reorient(values: Vec<f32>, dims: [usize; 3], map: &AxisMap) -> (Vec<f32>, [usize; 3]) {
    if *map == AxisMap::IDENTITY {
        return (values, dims);
    }
    let out_dims = map.source.map(|s| dims[s]);
    let src_stride = [1, dims[0], dims[0] * dims[1]];
    // Per grid axis: the stride in the source and the source offset of grid index 0.
    let stride = map.source.map(|s| src_stride[s] as isize);
    let mut base = 0isize;
    let mut step = [0isize; 3];
    for a in 0..3 {
        if map.flip[a] {
            base += stride[a] * (out_dims[a] as isize - 1);
            step[a] = -stride[a];
        } else {
            step[a] = stride[a];
        }
    }
    let mut out = Vec::with_capacity(values.len());
    for z in 0..out_dims[2] as isize {
        for y in 0..out_dims[1] as isize {
            let row = base + z * step[2] + y * step[1];
            out.extend((0..out_dims[0] as isize).map(|x| values[(row + x * step[0]) as usize]));
        }
    }
    (out, out_dims)
}

/// The cross product (slice normal = row direction × column direction).
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// The dot product.
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axes(directions: [[f64; 3]; 3]) -> PatientAxes {
        PatientAxes {
            directions,
            spacing: [0.5, 0.75, 2.0],
        }
    }

    #[test]
    fn standard_axial_is_identity() {
        let (map, o) = axes([[1., 0., 0.], [0., 1., 0.], [0., 0., 1.]]).grid_map();
        assert_eq!(map, AxisMap::IDENTITY);
        assert_eq!(
            o,
            Orientation::AxisAligned {
                file_axes: ["L".into(), "P".into(), "S".into()]
            }
        );
    }

    #[test]
    fn sagittal_with_flips_is_permuted_exactly() {
        // i = posterior→anterior (−P), j = superior→inferior (−S), k = +L: a sagittal stack.
        let a = axes([[0., -1., 0.], [0., 0., -1.], [1., 0., 0.]]);
        let (map, o) = a.grid_map();
        assert_eq!(map.source, [2, 0, 1]);
        assert_eq!(map.flip, [false, true, true]);
        assert_eq!(a.grid_spacing(&map), [2.0, 0.5, 0.75]);
        assert!(o.describe().contains("file axes AIL"), "{}", o.describe());
        // dims i=2, j=3, k=4; value = i + 10 j + 100 k.
        let dims = [2, 3, 4];
        let values: Vec<f32> = (0..24)
            .map(|n| (n % 2 + 10 * ((n / 2) % 3) + 100 * (n / 6)) as f32)
            .collect();
        let (out, out_dims) = reorient(values, dims, &map);
        assert_eq!(out_dims, [4, 2, 3]);
        // grid (x, y, z) = (k, 1 − i, 2 − j).
        for z in 0..3 {
            for y in 0..2 {
                for x in 0..4 {
                    let v = out[x + 4 * (y + 2 * z)];
                    let (i, j, k) = (1 - y, 2 - z, x);
                    assert_eq!(v, (i + 10 * j + 100 * k) as f32, "grid ({x},{y},{z})");
                }
            }
        }
    }

    #[test]
    fn oblique_keeps_own_frame_and_says_so() {
        let c = std::f64::consts::FRAC_1_SQRT_2;
        let (map, o) = axes([[c, c, 0.], [-c, c, 0.], [0., 0., 1.]]).grid_map();
        assert_eq!(map, AxisMap::IDENTITY);
        assert!(o.describe().starts_with("OBLIQUE"));
    }
}
