//! The explorer's data files, one per finished cell (`explorer/cells/<hash>.js`: its three
//! layers and its FLIP map against the reference) and one per reference
//! (`explorer/refs/<key>.js`). Each is a classic script that hands its data to
//! `volphotExplorerData(path, data)`, since a page opened from `file://` may load scripts
//! but may not fetch files.
//!
//! A file's first line records what it was made from (the film's and reference's sha256,
//! the exposure, the displayed layers, the format); a report keeps a file whose first line
//! matches, so only new or re-rendered cells cost time. Files are written atomically and
//! files of cells no longer in the plan are removed.

use std::collections::{BTreeMap, BTreeSet};
use std::io::Read as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use rayon::prelude::*;
use serde::Serialize;
use volphot::{Film, Layer, to_srgb8};

use super::pack::{pack_layer, pack_unit};
use crate::analyse::{displayed, flip_map};
use crate::report::collect::Collected;
use crate::store::{CellRecord, FileCheck, OutputDir, first_mismatch, read_reference_record};

/// Version of the data files' content; files of another version are written again
/// (2: pixel data may be binned).
const DATA_FORMAT: u32 = 2;

/// The explorer's folder inside the output folder.
pub(super) const FOLDER: &str = "explorer";

/// The layers a cell's displayed image sums (single always; multiple and emission when the
/// cell renders them), as in `analyse::displayed`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub(super) struct Shows {
    pub(super) multiple: bool,
    pub(super) emission: bool,
}

impl Shows {
    fn of(record: &CellRecord) -> Self {
        let integrator = &record.provenance.scene.integrator;
        Shows {
            multiple: integrator.multiple,
            emission: integrator.emission,
        }
    }

    /// The layer names, as the page sums them.
    pub(super) fn names(self) -> Vec<&'static str> {
        let mut names = vec![Layer::Single.name()];
        if self.multiple {
            names.push(Layer::Multiple.name());
        }
        if self.emission {
            names.push(Layer::Emission.name());
        }
        names
    }
}

/// A usable reference: its record parses and its files are whole.
struct ReferenceSource {
    key: String,
    dir: PathBuf,
    sha256: String,
    size: [usize; 2],
    bin: usize,
}

/// What a finished cell's data file is made from.
struct CellSource<'a> {
    /// Position in the collected cells.
    position: usize,
    hash: &'a str,
    dir: PathBuf,
    film_sha256: String,
    reference: Option<&'a ReferenceSource>,
    exposure: f32,
    shows: Shows,
    /// Side of the square bins its pixel data are averaged over (1: every pixel).
    bin: usize,
}

/// A finished cell's data as the manifest lists it.
#[derive(Debug, Clone)]
pub(super) struct CellData {
    /// Path of the data file, relative to the output folder (and to `report.html`).
    pub(super) path: String,
    /// Key of its reference when one is usable (then the file holds a FLIP map).
    pub(super) reference: Option<String>,
    pub(super) size: [usize; 2],
    pub(super) exposure: f32,
    pub(super) shows: Shows,
}

/// The data files of a report.
#[derive(Debug, Default)]
pub(super) struct DataIndex {
    /// By position in the collected cells (finished cells only).
    pub(super) cells: BTreeMap<usize, CellData>,
    /// Reference key → data file path.
    pub(super) references: BTreeMap<String, String>,
}

/// `explorer/cells/<hash>.js`.
fn cell_path(hash: &str) -> String {
    format!("{FOLDER}/cells/{hash}.js")
}

/// `explorer/refs/<key>.js`.
fn reference_path(key: &str) -> String {
    format!("{FOLDER}/refs/{key}.js")
}

/// The recorded sha256 of `name` in `dir`, or the file's checksum now (records written
/// before files were checked list none).
fn checksum(dir: &Path, files: &[FileCheck], name: &str) -> Result<String> {
    match files.iter().find(|f| f.name == name) {
        Some(f) => Ok(f.sha256.clone()),
        None => Ok(volphot::sha256_file(&dir.join(name))?),
    }
}

/// The bin side that brings an image of `size` within `max_side` pixels on its long side.
fn bin_for(size: [usize; 2], max_side: Option<usize>) -> usize {
    match max_side {
        Some(m) if m > 0 => size[0].max(size[1]).div_ceil(m).max(1),
        _ => 1,
    }
}

fn reference_source(
    out: &OutputDir,
    key: &str,
    max_side: Option<usize>,
) -> Result<Option<ReferenceSource>> {
    let dir = out.reference(key);
    let Ok(record) = read_reference_record(&dir) else {
        return Ok(None);
    };
    if first_mismatch(&dir, &record.files).is_some() || !dir.join("reference.exr").is_file() {
        return Ok(None);
    }
    let [w, h] = record.scene.camera.resolution;
    Ok(Some(ReferenceSource {
        key: key.to_string(),
        sha256: checksum(&dir, &record.files, "reference.exr")?,
        dir,
        size: [w as usize, h as usize],
        bin: bin_for([w as usize, h as usize], max_side),
    }))
}

impl CellSource<'_> {
    fn size(&self, record: &CellRecord) -> [usize; 2] {
        record
            .provenance
            .scene
            .camera
            .resolution
            .map(|n| n as usize)
    }

    /// The first line of the data file: everything the data depend on.
    fn stamp(&self) -> String {
        let source = format!(
            "cell data format {DATA_FORMAT}\nfilm {}\nreference {}\nexposure {}\nshows {:?}\nbin {}\n",
            self.film_sha256,
            self.reference.map_or("none", |r| r.sha256.as_str()),
            self.exposure.to_bits(),
            self.shows,
            self.bin
        );
        format!(
            "// volphot explorer data {}",
            volphot::sha256_bytes(source.as_bytes())
        )
    }
}

fn reference_stamp(reference: &ReferenceSource) -> String {
    let source = format!(
        "reference data format {DATA_FORMAT}\nreference {}\nbin {}\n",
        reference.sha256, reference.bin
    );
    format!(
        "// volphot explorer data {}",
        volphot::sha256_bytes(source.as_bytes())
    )
}

/// Whether `path` starts with `stamp` (then it holds the data that stamp describes).
fn is_current(path: &Path, stamp: &str) -> bool {
    let Ok(file) = std::fs::File::open(path) else {
        return false;
    };
    let mut head = Vec::with_capacity(stamp.len() + 1);
    if file
        .take(stamp.len() as u64 + 1)
        .read_to_end(&mut head)
        .is_err()
    {
        return false;
    }
    head.strip_suffix(b"\n") == Some(stamp.as_bytes())
}

/// The data object a script passes to the page.
#[derive(Serialize)]
struct Payload {
    width: usize,
    height: usize,
    /// Side of the square bins the values are means over (1: the film's own pixels).
    bin: usize,
    layers: BTreeMap<&'static str, Option<String>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    flip: Option<String>,
}

/// Writes `stamp`, then `volphotExplorerData("<path>", <payload>);`, atomically.
fn write_script(out: &OutputDir, path: &str, stamp: &str, payload: &Payload) -> Result<()> {
    let text = format!(
        "{stamp}\nvolphotExplorerData({}, {});\n",
        serde_json::to_string(path)?,
        serde_json::to_string(payload)?
    );
    volphot::write_atomic(&out.root().join(path), text.as_bytes())?;
    Ok(())
}

/// The mean of every `bin` × `bin` square of a `w` × `h` image (the last row and column of
/// squares cover what is left); returns the binned image and its size.
fn binned<T: Copy + Default + std::ops::Add<Output = T> + std::ops::Mul<f32, Output = T>>(
    values: &[T],
    [w, h]: [usize; 2],
    bin: usize,
) -> (Vec<T>, [usize; 2]) {
    if bin <= 1 {
        return (values.to_vec(), [w, h]);
    }
    let (bw, bh) = (w.div_ceil(bin), h.div_ceil(bin));
    let mut out = Vec::with_capacity(bw * bh);
    for by in 0..bh {
        for bx in 0..bw {
            let (x0, y0) = (bx * bin, by * bin);
            let (x1, y1) = ((x0 + bin).min(w), (y0 + bin).min(h));
            let mut sum = T::default();
            for y in y0..y1 {
                for x in x0..x1 {
                    sum = sum + values[y * w + x];
                }
            }
            out.push(sum * (1.0 / ((x1 - x0) * (y1 - y0)) as f32));
        }
    }
    (out, [bw, bh])
}

/// Each layer's packed data by name (`None`: all zero).
type PackedLayers = BTreeMap<&'static str, Option<String>>;

/// Every layer of a film, binned and packed; returns them and the binned size.
fn packed_layers(film: &Film, bin: usize) -> Result<(PackedLayers, [usize; 2])> {
    let size = [film.width(), film.height()];
    let mut layers = BTreeMap::new();
    let mut out_size = size;
    for &l in Layer::ALL.iter() {
        let (pixels, s) = binned(film.layer(l), size, bin);
        out_size = s;
        layers.insert(l.name(), pack_layer(&pixels)?);
    }
    Ok((layers, out_size))
}

fn write_reference(out: &OutputDir, reference: &ReferenceSource, film: &Film) -> Result<()> {
    let (layers, [width, height]) = packed_layers(film, reference.bin)?;
    let payload = Payload {
        width,
        height,
        bin: reference.bin,
        layers,
        flip: None,
    };
    write_script(
        out,
        &reference_path(&reference.key),
        &reference_stamp(reference),
        &payload,
    )
}

/// Reads the cell's film, computes its FLIP map against the reference (the displayed
/// images, tone-mapped as the report's FLIP column compares them) and writes the file.
fn write_cell(out: &OutputDir, cell: &CellSource<'_>, reference: Option<&Film>) -> Result<()> {
    let path = cell.dir.join("film.exr");
    let film = Film::read_exr(&path).with_context(|| format!("explorer data of {}", cell.hash))?;
    let (w, h) = (film.width(), film.height());
    let flip = match reference.filter(|r| r.width() == w && r.height() == h) {
        Some(reference) => {
            let show = |f: &Film| displayed(f, cell.shows.multiple, cell.shows.emission);
            let map = flip_map(
                &to_srgb8(&show(&film), cell.exposure),
                &to_srgb8(&show(reference), cell.exposure),
                w as u32,
                h as u32,
            );
            Some(pack_unit(&binned(&map, [w, h], cell.bin).0)?)
        }
        None => None,
    };
    let (layers, [width, height]) = packed_layers(&film, cell.bin)?;
    let payload = Payload {
        width,
        height,
        bin: cell.bin,
        layers,
        flip,
    };
    write_script(out, &cell_path(cell.hash), &cell.stamp(), &payload)
}

/// The sources of every finished cell and of the references they use.
fn sources<'a>(
    out: &OutputDir,
    cells: &'a [Collected],
    references: &'a BTreeMap<String, ReferenceSource>,
    max_side: Option<usize>,
) -> Result<Vec<CellSource<'a>>> {
    let mut sources = Vec::new();
    for (position, c) in cells.iter().enumerate() {
        let Some(record) = &c.record else { continue };
        let dir = out.cell(&c.planned.hash);
        let mut source = CellSource {
            position,
            hash: &c.planned.hash,
            film_sha256: checksum(&dir, &record.files, "film.exr")?,
            dir,
            reference: None,
            exposure: record.provenance.scene.film.exposure,
            shows: Shows::of(record),
            bin: 1,
        };
        let size = source.size(record);
        source.bin = bin_for(size, max_side);
        source.reference = c
            .planned
            .reference
            .as_ref()
            .and_then(|k| references.get(k))
            .filter(|r| r.size == size);
        sources.push(source);
    }
    Ok(sources)
}

/// Writes the data files that are missing or out of date and removes those of cells and
/// references that are gone.
pub(super) fn write_data(
    out: &OutputDir,
    cells: &[Collected],
    max_side: Option<usize>,
) -> Result<DataIndex> {
    let mut references = BTreeMap::new();
    let keys: BTreeSet<&String> = cells
        .iter()
        .filter(|c| c.record.is_some())
        .filter_map(|c| c.planned.reference.as_ref())
        .collect();
    for key in keys {
        if let Some(r) = reference_source(out, key, max_side)? {
            references.insert(key.clone(), r);
        }
    }
    let sources = sources(out, cells, &references, max_side)?;
    let stale: Vec<&CellSource<'_>> = sources
        .iter()
        .filter(|s| !is_current(&out.root().join(cell_path(s.hash)), &s.stamp()))
        .collect();
    // One reference film in memory at a time: the stale cells are grouped by reference.
    let mut groups: BTreeMap<Option<&str>, Vec<&CellSource<'_>>> = BTreeMap::new();
    for s in &stale {
        groups
            .entry(s.reference.map(|r| r.key.as_str()))
            .or_default()
            .push(s);
    }
    for reference in references.values() {
        let current = is_current(
            &out.root().join(reference_path(&reference.key)),
            &reference_stamp(reference),
        );
        let group = groups.remove(&Some(reference.key.as_str()));
        if current && group.is_none() {
            continue;
        }
        let film = Film::read_exr(&reference.dir.join("reference.exr"))
            .with_context(|| format!("explorer data of reference {}", reference.key))?;
        if !current {
            write_reference(out, reference, &film)?;
        }
        write_cells(out, group.unwrap_or_default(), Some(&film))?;
    }
    for group in groups.into_values() {
        write_cells(out, group, None)?;
    }
    let index = DataIndex {
        cells: sources
            .iter()
            .map(|s| {
                let record = cells[s.position].record.as_ref().expect("finished cell");
                let data = CellData {
                    path: cell_path(s.hash),
                    reference: s.reference.map(|r| r.key.clone()),
                    size: s.size(record),
                    exposure: s.exposure,
                    shows: s.shows,
                };
                (s.position, data)
            })
            .collect(),
        references: references
            .keys()
            .map(|k| (k.clone(), reference_path(k)))
            .collect(),
    };
    remove_unlisted(out, &index)?;
    Ok(index)
}

fn write_cells(
    out: &OutputDir,
    cells: Vec<&CellSource<'_>>,
    reference: Option<&Film>,
) -> Result<()> {
    cells
        .into_par_iter()
        .map(|c| write_cell(out, c, reference))
        .collect::<Result<Vec<()>>>()?;
    Ok(())
}

/// Removes data files no cell or reference of the index uses (a changed plan, a cell that
/// became damaged), and temporaries of killed reports.
fn remove_unlisted(out: &OutputDir, index: &DataIndex) -> Result<()> {
    let listed: BTreeSet<&str> = index
        .cells
        .values()
        .map(|c| c.path.as_str())
        .chain(index.references.values().map(String::as_str))
        .collect();
    for sub in ["cells", "refs"] {
        let dir = out.root().join(FOLDER).join(sub);
        crate::store::clean_stale(&dir);
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for entry in entries.flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            let path = format!("{FOLDER}/{sub}/{name}");
            if name.ends_with(".js") && !name.starts_with('.') && !listed.contains(path.as_str()) {
                std::fs::remove_file(entry.path())
                    .with_context(|| format!("removing {}", entry.path().display()))?;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bins_average_squares_and_keep_the_edges() {
        assert_eq!(bin_for([512, 512], Some(128)), 4);
        assert_eq!(bin_for([160, 100], Some(128)), 2);
        assert_eq!(bin_for([128, 64], Some(128)), 1);
        assert_eq!(bin_for([512, 512], None), 1);
        // 5 × 3 in bins of 2: columns {0,1} {2,3} {4}, rows {0,1} {2}.
        let values: Vec<f32> = (0..15).map(|i| i as f32).collect();
        let (b, size) = binned(&values, [5, 3], 2);
        assert_eq!(size, [3, 2]);
        assert_eq!(b, vec![3.0, 5.0, 6.5, 10.5, 12.5, 14.0]);
        // The mean is kept: a binned image is as bright as the film.
        let film: Vec<f32> = (0..64 * 48).map(|i| ((i * 7919) % 101) as f32).collect();
        let (b, size) = binned(&film, [64, 48], 4);
        let mean = |v: &[f32]| v.iter().sum::<f32>() / v.len() as f32;
        assert_eq!(size, [16, 12]);
        assert!((mean(&b) - mean(&film)).abs() < 1e-3);
    }
}
