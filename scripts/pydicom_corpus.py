"""pydicom's own test files as a reference for volphot's DICOM reader.

    python pydicom_corpus.py OUT

For every file bundled with pydicom (pydicom/data/test_files), writes to OUT:

* manifest.json: what pydicom makes of the file (read or not, pixel data decoded or why
  not, samples, frames, rows, columns, photometric interpretation, modality);
* ref/N.f32: for a decoded greyscale image, its modality values as little-endian float32,
  frames × rows × columns in the file's order: the stored values pydicom decodes, inverted
  for MONOCHROME1, times RescaleSlope plus RescaleIntercept — or, for RT Dose, times
  DoseGridScaling — computed in float64 and rounded once to float32 (what volphot does);
* placed/N.dcm: a single-frame greyscale image without ImagePositionPatient given one
  (with ImageOrientationPatient and PixelSpacing if missing), so that its pixel data are
  decoded too (JPEG extended, deflate, MONOCHROME1 …); pixel bytes and transfer syntax
  untouched;
* series/N/s0..s2.dcm: a single-frame image with a position and an orientation copied
  three times by pydicom, 1 mm (or SliceThickness) apart along the slice normal, with a new
  SOPInstanceUID each; the pixel bytes and the transfer syntax are left untouched.

scripts/pydicom-corpus.sh installs pydicom and its decoders into a virtual environment;
crates/core/tests/it/dicom.rs (`pydicom_corpus_…`) reads the output and compares.
"""

import copy
import json
import sys
import warnings
from pathlib import Path

import numpy as np
import pydicom
from pydicom.uid import generate_uid

SERIES_SLICES = 3


def number(ds, keyword, default):
    """A numeric element's value, `default` when absent or empty."""
    value = ds.get(keyword)
    if value is None or value == "":
        return default
    return float(value)


def modality_values(ds, stored):
    """Stored values → modality values, as volphot defines them (see the docstring)."""
    values = stored.astype(np.float64)
    if ds.get("PhotometricInterpretation") == "MONOCHROME1":
        bits = int(ds.BitsStored)
        signed = int(ds.get("PixelRepresentation", 0)) == 1
        values = -1.0 - values if signed else float(2**bits - 1) - values
    if str(ds.get("Modality", "")) == "RTDOSE":
        slope, intercept = number(ds, "DoseGridScaling", 1.0), 0.0
    else:
        slope = number(ds, "RescaleSlope", 1.0)
        intercept = number(ds, "RescaleIntercept", 0.0)
    return (values * slope + intercept).astype("<f4")


def describe(path, root):
    """What pydicom makes of one file; the dataset when it has decoded pixels."""
    entry = {"file": str(path.relative_to(root)), "path": str(path)}
    try:
        ds = pydicom.dcmread(path)
    except Exception as e:  # noqa: BLE001 - any failure is a class of its own
        entry["pydicom"] = f"not read: {type(e).__name__}"
        return entry, None
    entry["pydicom"] = "read"
    if "PixelData" not in ds:
        entry["pixels"] = "none"
        return entry, None
    for keyword in ("SamplesPerPixel", "PhotometricInterpretation", "Modality", "Rows", "Columns"):
        value = ds.get(keyword)
        entry[keyword] = value if isinstance(value, (int, str)) or value is None else str(value)
    try:
        entry["frames"] = int(ds.get("NumberOfFrames") or 1)
        stored = ds.pixel_array
    except Exception as e:  # noqa: BLE001
        entry["pixels"] = f"cannot decode: {type(e).__name__}: {str(e).splitlines()[0][:120]}"
        return entry, None
    entry["pixels"] = "decoded"
    return entry, (ds, stored)


def write_reference(entry, ds, stored, out, index):
    if int(ds.get("SamplesPerPixel") or 1) != 1 or "ModalityLUTSequence" in ds:
        return
    frames = entry["frames"]
    values = modality_values(ds, stored).reshape(frames, int(ds.Rows), int(ds.Columns))
    name = f"ref/{index}.f32"
    values.tofile(out / name)
    entry["reference"] = name
    entry["shape"] = list(values.shape)


def write_series(entry, ds, out, index):
    """Three copies of a single-frame image along its slice normal."""
    if entry["frames"] != 1 or "ImagePositionPatient" not in ds or "ImageOrientationPatient" not in ds:
        return
    try:
        position = np.array([float(v) for v in ds.ImagePositionPatient])
        o = [float(v) for v in ds.ImageOrientationPatient]
        normal = np.cross(o[:3], o[3:])
        step = number(ds, "SliceThickness", 0.0)
        step = step if step > 0 else 1.0
        folder = out / "series" / str(index)
        folder.mkdir(parents=True)
        for k in range(SERIES_SLICES):
            copy_ = copy.deepcopy(ds)
            at = position + k * step * normal
            copy_.ImagePositionPatient = [f"{v:.6f}" for v in at]
            uid = generate_uid()
            copy_.SOPInstanceUID = uid
            copy_.file_meta.MediaStorageSOPInstanceUID = uid
            copy_.save_as(folder / f"s{k}.dcm", enforce_file_format=False)
        entry["series"] = f"series/{index}"
    except Exception as e:  # noqa: BLE001
        entry["series_error"] = f"{type(e).__name__}: {str(e).splitlines()[0][:120]}"


def write_placed(entry, ds, out, index):
    """A copy of a single-frame greyscale image without a position, placed at the origin."""
    if entry.get("frames") != 1 or int(ds.get("SamplesPerPixel") or 1) != 1:
        return
    if "ImagePositionPatient" in ds:
        return
    try:
        placed = copy.deepcopy(ds)
        placed.ImagePositionPatient = ["0", "0", "0"]
        if "ImageOrientationPatient" not in placed:
            placed.ImageOrientationPatient = ["1", "0", "0", "0", "1", "0"]
        if "PixelSpacing" not in placed:
            placed.PixelSpacing = ["1", "1"]
        (out / "placed").mkdir(exist_ok=True)
        name = f"placed/{index}.dcm"
        placed.save_as(out / name, enforce_file_format=False)
        entry["placed"] = name
    except Exception as e:  # noqa: BLE001
        entry["placed_error"] = f"{type(e).__name__}: {str(e).splitlines()[0][:120]}"


def main():
    out = Path(sys.argv[1])
    (out / "ref").mkdir(parents=True, exist_ok=True)
    root = Path(pydicom.__file__).parent / "data" / "test_files"
    entries = []
    warnings.simplefilter("ignore")
    for index, path in enumerate(sorted(p for p in root.rglob("*") if p.is_file())):
        entry, decoded = describe(path, root)
        if decoded is not None:
            ds, stored = decoded
            write_reference(entry, ds, stored, out, index)
            write_series(entry, ds, out, index)
        elif entry.get("pixels", "").startswith("cannot decode"):
            ds = pydicom.dcmread(path)
            entry.setdefault("frames", 1)
        if entry.get("pixels", "none") != "none" and "frames" in entry:
            write_placed(entry, ds, out, index)
        entries.append(entry)
    manifest = {"pydicom": pydicom.__version__, "files": entries}
    (out / "manifest.json").write_text(json.dumps(manifest, indent=1))


if __name__ == "__main__":
    main()
