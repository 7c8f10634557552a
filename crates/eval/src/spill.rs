//! Fixed-size records kept for later passes: in memory, or in an unnamed temporary file
//! (removed by the operating system when closed, even if the process is killed) so that an
//! evaluation's memory does not grow with the length of the pass.

use std::fs::File;
use std::io::{BufReader, BufWriter, Read, Seek, SeekFrom, Write};
use std::marker::PhantomData;
use std::path::{Path, PathBuf};

use crate::EvalError;

/// A record of a fixed number of bytes.
pub(crate) trait Record: Sized {
    /// Bytes per record.
    const SIZE: usize;
    /// Appends the record's `SIZE` bytes.
    fn encode(&self, out: &mut Vec<u8>);
    /// Reads a record from `SIZE` bytes.
    fn decode(bytes: &[u8]) -> Self;
}

enum Store {
    Memory(Vec<u8>),
    Writing(BufWriter<File>),
    Sealed(File),
}

/// Records appended once, then read in order as often as needed.
pub(crate) struct Spill<T> {
    store: Store,
    /// Names the temporary file's folder in errors.
    dir: PathBuf,
    len: usize,
    /// Reading began: no more records.
    sealed: bool,
    scratch: Vec<u8>,
    _record: PhantomData<T>,
}

impl<T: Record> Spill<T> {
    /// Records kept in memory.
    pub(crate) fn memory() -> Self {
        Self {
            store: Store::Memory(Vec::new()),
            dir: PathBuf::new(),
            len: 0,
            sealed: false,
            scratch: Vec::with_capacity(T::SIZE),
            _record: PhantomData,
        }
    }

    /// Records kept in an unnamed temporary file in `dir`.
    ///
    /// # Errors
    /// [`EvalError::Io`] naming `dir` when no file can be made there.
    pub(crate) fn in_dir(dir: &Path) -> Result<Self, EvalError> {
        let file = tempfile::tempfile_in(dir).map_err(|e| EvalError::io(dir, e))?;
        Ok(Self {
            store: Store::Writing(BufWriter::with_capacity(1 << 16, file)),
            dir: dir.to_path_buf(),
            len: 0,
            sealed: false,
            scratch: Vec::with_capacity(T::SIZE),
            _record: PhantomData,
        })
    }

    /// Where the records go: a temporary file in `dir`, or memory.
    pub(crate) fn new(dir: Option<&Path>) -> Result<Self, EvalError> {
        dir.map_or_else(|| Ok(Self::memory()), Self::in_dir)
    }

    /// Number of records.
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// Appends a record.
    ///
    /// # Errors
    /// [`EvalError::Io`] when the temporary file cannot be written (disk full), or after
    /// [`Spill::for_each`] was called.
    pub(crate) fn push(&mut self, record: &T) -> Result<(), EvalError> {
        if self.sealed {
            return Err(EvalError::Invalid(
                "internal: record appended after reading began".into(),
            ));
        }
        self.scratch.clear();
        record.encode(&mut self.scratch);
        debug_assert_eq!(self.scratch.len(), T::SIZE);
        match &mut self.store {
            Store::Memory(v) => v.extend_from_slice(&self.scratch),
            Store::Writing(w) => w
                .write_all(&self.scratch)
                .map_err(|e| EvalError::io(&self.dir, e))?,
            Store::Sealed(_) => unreachable!("sealed spills refuse records above"),
        }
        self.len += 1;
        Ok(())
    }

    /// Ends appending: the records can be read from now on.
    ///
    /// # Errors
    /// [`EvalError::Io`] when the temporary file cannot be flushed (disk full).
    pub(crate) fn seal(&mut self) -> Result<(), EvalError> {
        self.sealed = true;
        if let Store::Writing(_) = self.store {
            let Store::Writing(w) = std::mem::replace(&mut self.store, Store::Memory(Vec::new()))
            else {
                unreachable!("matched above")
            };
            let file = w
                .into_inner()
                .map_err(|e| EvalError::io(&self.dir, e.into_error()))?;
            self.store = Store::Sealed(file);
        }
        Ok(())
    }

    /// Calls `f` with every record, in the order appended.
    ///
    /// # Errors
    /// [`EvalError::Io`] when the temporary file cannot be read back; whatever `f` returns;
    /// [`EvalError::Invalid`] before [`Spill::seal`].
    pub(crate) fn for_each(
        &self,
        mut f: impl FnMut(T) -> Result<(), EvalError>,
    ) -> Result<(), EvalError> {
        let io = |e| EvalError::io(&self.dir, e);
        match &self.store {
            Store::Memory(v) if self.sealed => {
                v.chunks_exact(T::SIZE).try_for_each(|b| f(T::decode(b)))
            }
            Store::Sealed(file) => {
                let mut file: &File = file;
                file.seek(SeekFrom::Start(0)).map_err(io)?;
                let mut r = BufReader::with_capacity(1 << 16, file);
                let mut buf = vec![0u8; T::SIZE];
                for _ in 0..self.len {
                    r.read_exact(&mut buf).map_err(io)?;
                    f(T::decode(&buf))?;
                }
                Ok(())
            }
            _ => Err(EvalError::Invalid(
                "internal: records read before they were sealed".into(),
            )),
        }
    }
}

/// Little-endian field readers for [`Record::decode`].
pub(crate) struct Fields<'a>(pub &'a [u8]);

impl Fields<'_> {
    pub(crate) fn f64(&mut self) -> f64 {
        let (a, rest) = self.0.split_at(8);
        self.0 = rest;
        f64::from_le_bytes(a.try_into().unwrap_or([0; 8]))
    }

    pub(crate) fn u64(&mut self) -> u64 {
        let (a, rest) = self.0.split_at(8);
        self.0 = rest;
        u64::from_le_bytes(a.try_into().unwrap_or([0; 8]))
    }

    pub(crate) fn u8(&mut self) -> u8 {
        let (a, rest) = self.0.split_at(1);
        self.0 = rest;
        a[0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, PartialEq)]
    struct R(u64, f64, u8);

    impl Record for R {
        const SIZE: usize = 17;
        fn encode(&self, out: &mut Vec<u8>) {
            out.extend(self.0.to_le_bytes());
            out.extend(self.1.to_le_bytes());
            out.push(self.2);
        }
        fn decode(b: &[u8]) -> Self {
            let mut f = Fields(b);
            R(f.u64(), f.f64(), f.u8())
        }
    }

    #[test]
    fn records_come_back_in_order_from_memory_and_from_a_file_as_often_as_asked() {
        let dir = tempfile::tempdir().unwrap();
        for mut s in [Spill::<R>::memory(), Spill::in_dir(dir.path()).unwrap()] {
            for i in 0..10_000u64 {
                s.push(&R(i, i as f64 * 0.5, (i % 7) as u8)).unwrap();
            }
            assert_eq!(s.len(), 10_000);
            assert!(s.for_each(|_| Ok(())).is_err());
            s.seal().unwrap();
            for _ in 0..2 {
                let mut i = 0u64;
                s.for_each(|r| {
                    assert_eq!(r, R(i, i as f64 * 0.5, (i % 7) as u8));
                    i += 1;
                    Ok(())
                })
                .unwrap();
                assert_eq!(i, 10_000);
            }
            assert!(s.push(&R(0, 0.0, 0)).is_err());
        }
        // The file has no name: nothing is left in the folder.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}
