//! Frames of a video file, decoded as they are read, from Python.

use std::sync::Mutex;

use endoloc_data::stream::FrameStream;
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;

use crate::convert::{array_from_gray, lib_error, path_from_py};

/// The frames of a video file (whatever FFmpeg decodes; `ffmpeg` and `ffprobe` on the PATH),
/// decoded while they are read, grey, as `localize --live --video` reads them: iterate for
/// `(index, time_s, image)` — the frame's index in the video, its presentation time (seconds,
/// the video's clock) and an `(H, W)` `uint8` array. `size=(width, height)` resizes them (the
/// aspect ratio must stay; e.g. a `Localizer`'s camera size); default: the video's own. A frame
/// FFmpeg reports damaged comes with `damaged` set to its message until the next frame.
#[pyclass(module = "endoloc", name = "VideoFrames")]
pub struct PyVideoFrames {
    stream: Mutex<FrameStream>,
    damage: Option<String>,
}

#[pymethods]
impl PyVideoFrames {
    #[new]
    #[pyo3(signature = (path, size=None))]
    fn new(path: &Bound<'_, PyAny>, size: Option<(u32, u32)>) -> PyResult<Self> {
        let path = path_from_py(path)?;
        let size = match size {
            Some(s) => s,
            None => endoloc_data::import::video::frame_size(&path).map_err(lib_error)?,
        };
        let stream = FrameStream::open_video(&path, size).map_err(lib_error)?;
        Ok(PyVideoFrames {
            stream: Mutex::new(stream),
            damage: None,
        })
    }

    /// The size of the frames handed out, `(width, height)` pixels.
    #[getter]
    fn size(&self) -> PyResult<(u32, u32)> {
        Ok(self.lock()?.size())
    }

    /// The video's own frame size, `(width, height)` pixels.
    #[getter]
    fn native_size(&self) -> PyResult<(u32, u32)> {
        Ok(self.lock()?.native_size())
    }

    /// FFmpeg's message when the last frame handed out was decoded from damaged data.
    #[getter]
    fn damaged(&self) -> Option<String> {
        self.damage.clone()
    }

    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    fn __next__<'py>(
        &mut self,
        py: Python<'py>,
    ) -> PyResult<Option<(usize, f64, Bound<'py, PyAny>)>> {
        let next = {
            let stream = &self.stream;
            py.detach(|| {
                stream
                    .lock()
                    .map_err(|_| PyRuntimeError::new_err("the video stream failed"))
                    .map(|mut s| s.next_frame())
            })?
        };
        match next {
            None => Ok(None),
            Some(Err(e)) => Err(lib_error(e)),
            Some(Ok(frame)) => {
                self.damage = frame.damage;
                Ok(Some((
                    frame.index,
                    frame.time_s,
                    array_from_gray(py, frame.image)?,
                )))
            }
        }
    }
}

impl PyVideoFrames {
    fn lock(&self) -> PyResult<std::sync::MutexGuard<'_, FrameStream>> {
        self.stream
            .lock()
            .map_err(|_| PyRuntimeError::new_err("the video stream failed"))
    }
}
