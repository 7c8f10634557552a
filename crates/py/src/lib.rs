//! endoloc from Python: the `endoloc._endoloc` extension module (PyO3), wrapped by the
//! `endoloc` package in `python/`.
//!
//! Everything here calls the library as the command line does — datasets through
//! `endoloc-data`, the model through `endoloc-net`, frames through `LocalizeJob::localizer`,
//! and every job through its serde struct — so that Python and `endoloc` give the same
//! results. Conventions are the library's: millimetres, poses `T_wc` (camera-to-world) as 4×4
//! `float64` arrays, OpenCV camera axes, images as `uint8` NumPy arrays.

mod convert;
mod dataset;
mod jobs;
mod localizer;
mod options;
mod video;

use pyo3::prelude::*;

/// endoloc's library: datasets, the zone classifier, the localizer and every job.
#[pymodule]
fn _endoloc(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("EndolocError", m.py().get_type::<convert::EndolocError>())?;
    m.add_class::<dataset::PyCamera>()?;
    m.add_class::<dataset::PyDataset>()?;
    m.add_class::<dataset::PySequence>()?;
    m.add_class::<localizer::PyModel>()?;
    m.add_class::<localizer::PyLocalizer>()?;
    m.add_class::<localizer::PyFrameResult>()?;
    m.add_class::<jobs::PyReport>()?;
    m.add_class::<video::PyVideoFrames>()?;
    m.add_function(wrap_pyfunction!(dataset::read_tum, m)?)?;
    m.add_function(wrap_pyfunction!(dataset::write_tum, m)?)?;
    m.add_function(wrap_pyfunction!(jobs::run_job, m)?)?;
    m.add_function(wrap_pyfunction!(jobs::run_config, m)?)?;
    m.add_function(wrap_pyfunction!(jobs::job_options, m)?)?;
    m.add_function(wrap_pyfunction!(localizer::time_rust_calls, m)?)?;
    Ok(())
}

// Python's allocator aligns objects to 16 bytes: a class whose Rust value needs more would be
// misaligned (parts of the classifier need 64), so such values are boxed. Checked here.
const _: () = {
    assert!(std::mem::align_of::<localizer::PyModel>() <= 16);
    assert!(std::mem::align_of::<localizer::PyLocalizer>() <= 16);
    assert!(std::mem::align_of::<localizer::PyFrameResult>() <= 16);
    assert!(std::mem::align_of::<dataset::PyDataset>() <= 16);
    assert!(std::mem::align_of::<dataset::PySequence>() <= 16);
    assert!(std::mem::align_of::<dataset::PyCamera>() <= 16);
    assert!(std::mem::align_of::<jobs::PyReport>() <= 16);
    assert!(std::mem::align_of::<video::PyVideoFrames>() <= 16);
};
