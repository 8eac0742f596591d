//! HDF5 helpers shared by the result file and the sample file: attributes, datasets written
//! chunked and compressed when large or plain when written at every increment, read back
//! with their shapes checked, and an internal failure type that becomes an input error
//! (reading a file the user gave) or an I/O error (writing).
//!
//! Attributes, plain datasets and the rows of growable ones, which every increment writes,
//! go to libhdf5 directly with its default property lists: the crate's builders make three
//! property lists and two datatypes for each, which took twice as long as the write itself.

use crate::{Error, InputError};
use hdf5::types::VarLenUnicode;
use hdf5::{h5check, Dataset, Datatype, Group, H5Type, Location};
use hdf5_sys::h5::hsize_t;
use hdf5_sys::h5a::{H5Acreate2, H5Aexists, H5Aopen, H5Awrite};
use hdf5_sys::h5d::{H5Dcreate2, H5Dget_space, H5Dopen2, H5Dset_extent, H5Dwrite};
use hdf5_sys::h5i::{hid_t, H5Idec_ref};
use hdf5_sys::h5p::H5P_DEFAULT;
use hdf5_sys::h5s::{
    H5S_seloper_t, H5Screate, H5Screate_simple, H5Sselect_hyperslab, H5S_ALL, H5S_SCALAR,
};
use ndarray::{ArrayView, ArrayView1};
use std::ffi::CString;
use std::path::Path;
use std::ptr::null;
use std::str::FromStr;

/// Datasets with fewer elements than this are stored plain: filters on tiny data only cost.
const CHUNK_THRESHOLD: usize = 512;

/// Elements per chunk of a large dataset (128 KiB of f64).
const CHUNK_ELEMENTS: usize = 16_384;

/// An internal failure with its message; turned into [`Error::Io`] when writing and into
/// [`Error::Input`] when reading a file the user gave.
#[derive(Debug)]
pub(crate) struct Fail(pub(crate) String);

impl From<hdf5::Error> for Fail {
    fn from(e: hdf5::Error) -> Self {
        Fail(e.to_string())
    }
}

impl From<ndarray::ShapeError> for Fail {
    fn from(e: ndarray::ShapeError) -> Self {
        Fail(e.to_string())
    }
}

impl From<String> for Fail {
    fn from(s: String) -> Self {
        Fail(s)
    }
}

pub(crate) type R<T> = std::result::Result<T, Fail>;

pub(crate) fn input_error(path: &Path, message: impl Into<String>) -> Error {
    Error::Input(InputError::new(path.display().to_string(), message))
}

pub(crate) fn read_error(path: &Path) -> impl FnOnce(Fail) -> Error + '_ {
    move |f| input_error(path, f.0)
}

pub(crate) fn write_error(path: &Path) -> impl FnOnce(Fail) -> Error + '_ {
    move |f| Error::io(path.display(), f.0)
}

/// Run `read` on a file the user named in a child process first. libhdf5 can crash (seen:
/// SIGSEGV in `H5HG_read`) or loop for ever (seen: in `H5HG__protect`) on a corrupt file,
/// which would end or hang the whole program with no message; in a child it only ends the
/// child. A child killed by a signal, or not done within 20 s (plus a second per 10 MB),
/// makes the file bad input; otherwise the caller reads the file itself, and any error it
/// meets is reported as usual. `read`'s answer does not matter, only that it returns.
pub(crate) fn read_in_child(path: &Path, read: impl FnOnce() -> bool) -> Result<(), Error> {
    let size = std::fs::metadata(path).map_or(0, |m| m.len());
    let limit = std::time::Duration::from_secs(20 + size / 10_000_000);
    // Fork while holding hdf5's lock, so that no other thread of ours is inside libhdf5 at
    // the fork (the child would wait for that lock for ever); the child, a copy of this
    // thread, holds it. The lock is let go only once the child has closed the files other
    // threads have open: until then it holds their locks too, and a thread opening one of
    // them again would find it locked.
    let pid = hdf5::sync::sync(|| {
        let mut pipe = [-1; 2];
        // SAFETY: makes a pipe in this process, closed on exec so that no program started
        // meanwhile keeps it open; on failure `pipe` stays -1 and the fork goes on without
        // the wait.
        unsafe { libc::pipe2(pipe.as_mut_ptr(), libc::O_CLOEXEC) };
        let [wait_end, tell_end] = pipe;
        // SAFETY: the child runs `read` and leaves by `_exit`, touching nothing shared but the
        // file; no lock the child needs is held by another thread (see above).
        let pid = unsafe { libc::fork() };
        if pid == 0 {
            // Files other threads have open were inherited with their locks: let them go
            // (the child opens its own), then the pipe's end, which tells the parent.
            // SAFETY: closes this process's descriptors from 3 up, `tell_end` last (an empty
            // range, below 3 or without a pipe, closes nothing); nothing here uses them.
            unsafe {
                let keep = tell_end.max(2) as u32;
                libc::syscall(libc::SYS_close_range, 3u32, keep - 1, 0u32);
                libc::syscall(libc::SYS_close_range, keep + 1, u32::MAX, 0u32);
                libc::close(tell_end);
            }
            // Gone by itself after the time limit, even if this process is killed first
            // and no one is left to kill it (SIGALRM ends a process).
            // SAFETY: only sets this process's timer.
            unsafe { libc::alarm(limit.as_secs() as libc::c_uint + 1) };
            let code = match std::panic::catch_unwind(std::panic::AssertUnwindSafe(read)) {
                Ok(_) => 0,
                Err(_) => 1,
            };
            // SAFETY: ends the child at once, running no destructors and flushing nothing.
            unsafe { libc::_exit(code) }
        }
        // SAFETY: closes this process's ends of the pipe after reading from it, which
        // returns once the child has closed its end (or has ended).
        unsafe {
            libc::close(tell_end);
            if pid > 0 {
                let mut byte = 0u8;
                // A signal may cut the read short; only the child's end closing ends it.
                while libc::read(wait_end, (&mut byte as *mut u8).cast(), 1) < 0
                    && std::io::Error::last_os_error().kind() == std::io::ErrorKind::Interrupted
                {
                }
            }
            libc::close(wait_end);
        }
        pid
    });
    if pid < 0 {
        return Err(Error::io(
            path.display(),
            format!(
                "cannot start a process to read it: {}",
                std::io::Error::last_os_error()
            ),
        ));
    }
    let start = std::time::Instant::now();
    let mut status = 0;
    loop {
        // SAFETY: waits for our own child.
        let done = unsafe { libc::waitpid(pid, &mut status, libc::WNOHANG) };
        if done == pid {
            break;
        }
        if done < 0 {
            return Err(Error::io(
                path.display(),
                format!("reading it: {}", std::io::Error::last_os_error()),
            ));
        }
        if start.elapsed() > limit {
            // SAFETY: kills and reaps our own child.
            unsafe {
                libc::kill(pid, libc::SIGKILL);
                libc::waitpid(pid, &mut status, 0);
            }
            return Err(input_error(
                path,
                format!(
                    "is corrupt: reading it did not finish in {} s",
                    limit.as_secs()
                ),
            ));
        }
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    if libc::WIFSIGNALED(status) {
        return Err(input_error(
            path,
            format!(
                "is corrupt: reading it crashed the HDF5 library (signal {})",
                libc::WTERMSIG(status)
            ),
        ));
    }
    if libc::WEXITSTATUS(status) != 0 {
        return Err(input_error(path, "is corrupt: reading it failed"));
    }
    Ok(())
}

/// Set a scalar attribute, writing over an existing one.
pub(crate) fn set_attr<T: H5Type>(loc: &Location, name: &str, value: &T) -> R<()> {
    let dtype = Datatype::from_type::<T>()?;
    let c_name = c_name(name)?;
    hdf5::sync::sync(|| {
        // SAFETY: the ids are valid while `loc` and `dtype` live; `value` is one `T`.
        unsafe {
            let attr = if h5check(H5Aexists(loc.id(), c_name.as_ptr()))? > 0 {
                Handle::new(H5Aopen(loc.id(), c_name.as_ptr(), H5P_DEFAULT))?
            } else {
                let space = Handle::new(H5Screate(H5S_SCALAR))?;
                Handle::new(H5Acreate2(
                    loc.id(),
                    c_name.as_ptr(),
                    dtype.id(),
                    space.0,
                    H5P_DEFAULT,
                    H5P_DEFAULT,
                ))?
            };
            h5check(H5Awrite(attr.0, dtype.id(), (value as *const T).cast()))?;
        }
        Ok(())
    })
}

pub(crate) fn set_str_attr(loc: &Location, name: &str, value: &str) -> R<()> {
    set_attr(loc, name, &vlen(value)?)
}

pub(crate) fn vlen(s: &str) -> R<VarLenUnicode> {
    VarLenUnicode::from_str(s).map_err(|e| Fail(format!("string {s:?}: {e}")))
}

pub(crate) fn get_attr<T: H5Type>(loc: &Location, name: &str) -> R<T> {
    loc.attr(name)
        .and_then(|a| a.read_scalar::<T>())
        .map_err(|e| Fail(format!("attribute `{name}` of `{}`: {e}", loc.name())))
}

pub(crate) fn get_str_attr(loc: &Location, name: &str) -> R<String> {
    Ok(get_attr::<VarLenUnicode>(loc, name)?.as_str().to_owned())
}

pub(crate) fn get_count(loc: &Location, name: &str) -> R<usize> {
    let v = get_attr::<i64>(loc, name)?;
    usize::try_from(v).map_err(|_| Fail(format!("attribute `{name}` of `{}` is {v}", loc.name())))
}

/// Write a dataset: chunked, shuffled and deflated when large, plain when small. Zero-size
/// arrays are plain too (HDF5 cannot chunk them).
pub(crate) fn put<T: H5Type, D: ndarray::Dimension>(
    g: &Group,
    name: &str,
    data: ArrayView<T, D>,
) -> R<()> {
    let shape = data.shape().to_vec();
    let builder = g.new_dataset_builder();
    if data.len() >= CHUNK_THRESHOLD {
        let row = shape[1..].iter().product::<usize>().max(1);
        let mut chunk = shape.clone();
        chunk[0] = (CHUNK_ELEMENTS / row).clamp(1, shape[0]);
        let builder = builder.with_data(data).chunk(chunk).shuffle();
        if hdf5::filters::deflate_available() {
            builder.deflate(4).create(name)?;
        } else {
            builder.create(name)?;
        }
    } else {
        builder.with_data(data).create(name)?;
    }
    Ok(())
}

/// Write a dataset plain (contiguous, unfiltered): for the data written at every increment,
/// which compression would take longer to write than the solver takes to compute.
pub(crate) fn put_plain<T: H5Type + Clone, D: ndarray::Dimension>(
    g: &Group,
    name: &str,
    data: ArrayView<T, D>,
) -> R<()> {
    let data = data.as_standard_layout();
    let dims: Vec<hsize_t> = data.shape().iter().map(|&n| n as hsize_t).collect();
    let dtype = Datatype::from_type::<T>()?;
    let c_name = c_name(name)?;
    hdf5::sync::sync(|| {
        // SAFETY: the ids are valid while `g` and `dtype` live; `data` is contiguous, of
        // shape `dims`.
        unsafe {
            let space = Handle::new(H5Screate_simple(dims.len() as _, dims.as_ptr(), null()))?;
            let ds = Handle::new(H5Dcreate2(
                g.id(),
                c_name.as_ptr(),
                dtype.id(),
                space.0,
                H5P_DEFAULT,
                H5P_DEFAULT,
                H5P_DEFAULT,
            ))?;
            h5check(H5Dwrite(
                ds.0,
                dtype.id(),
                H5S_ALL,
                H5S_ALL,
                H5P_DEFAULT,
                data.as_ptr().cast(),
            ))?;
        }
        Ok(())
    })
}

/// Write `values` as row `row` of a growable dataset `name` of `g`, growing it to `row + 1`
/// rows: a table of `values.len()` columns, or a column (one value a row) when not `table`.
pub(crate) fn put_row<T: H5Type>(
    g: &Group,
    name: &str,
    row: usize,
    values: &[T],
    table: bool,
) -> R<()> {
    let dtype = Datatype::from_type::<T>()?;
    let c_name = c_name(name)?;
    let (row, width) = (row as hsize_t, values.len() as hsize_t);
    let (size, start, count) = match table {
        true => (vec![row + 1, width], vec![row, 0], vec![1, width]),
        false => (vec![row + 1], vec![row], vec![1]),
    };
    hdf5::sync::sync(|| {
        // SAFETY: the ids are valid while `g` and `dtype` live; `values` is the `count` of
        // the selection.
        unsafe {
            let ds = Handle::new(H5Dopen2(g.id(), c_name.as_ptr(), H5P_DEFAULT))?;
            h5check(H5Dset_extent(ds.0, size.as_ptr()))?;
            if values.is_empty() {
                return Ok(());
            }
            let file_space = Handle::new(H5Dget_space(ds.0))?;
            h5check(H5Sselect_hyperslab(
                file_space.0,
                H5S_seloper_t::H5S_SELECT_SET,
                start.as_ptr(),
                null(),
                count.as_ptr(),
                null(),
            ))?;
            let memory = Handle::new(H5Screate_simple(count.len() as _, count.as_ptr(), null()))?;
            h5check(H5Dwrite(
                ds.0,
                dtype.id(),
                memory.0,
                file_space.0,
                H5P_DEFAULT,
                values.as_ptr().cast(),
            ))?;
        }
        Ok(())
    })
}

/// An identifier made by a direct libhdf5 call, let go when dropped.
struct Handle(hid_t);

impl Handle {
    /// The identifier a call returned, or the library's error.
    fn new(id: hid_t) -> R<Handle> {
        Ok(Handle(h5check(id)?))
    }
}

impl Drop for Handle {
    fn drop(&mut self) {
        // SAFETY: an identifier of ours, given up once.
        unsafe { H5Idec_ref(self.0) };
    }
}

fn c_name(name: &str) -> R<CString> {
    CString::new(name).map_err(|_| Fail(format!("name {name:?} holds a NUL")))
}

pub(crate) fn put_strings(g: &Group, name: &str, values: &[String]) -> R<()> {
    let v = values.iter().map(|s| vlen(s)).collect::<R<Vec<_>>>()?;
    put(g, name, ArrayView1::from(&v[..]))
}

pub(crate) fn put_text(g: &Group, name: &str, text: &str) -> R<()> {
    g.new_dataset::<VarLenUnicode>()
        .create(name)?
        .write_scalar(&vlen(text)?)?;
    Ok(())
}

pub(crate) fn dataset(g: &Group, name: &str) -> R<Dataset> {
    g.dataset(name)
        .map_err(|e| Fail(format!("dataset `{}/{name}`: {e}", g.name())))
}

/// A 1-D dataset, of length `len` when given.
pub(crate) fn read_vec<T: H5Type>(g: &Group, name: &str, len: Option<usize>) -> R<Vec<T>> {
    let ds = dataset(g, name)?;
    let shape = ds.shape();
    if shape.len() != 1 || len.is_some_and(|n| n != shape[0]) {
        return Err(Fail(format!(
            "dataset `{}/{name}` has shape {shape:?}, expected ({},)",
            g.name(),
            len.map_or("n".into(), |n| n.to_string())
        )));
    }
    ds.read_raw::<T>()
        .map_err(|e| Fail(format!("dataset `{}/{name}`: {e}", g.name())))
}

/// An n x C dataset as rows, with n = `len` when given.
pub(crate) fn read_rows<T: H5Type + Copy + Default, const C: usize>(
    g: &Group,
    name: &str,
    len: Option<usize>,
) -> R<Vec<[T; C]>> {
    let ds = dataset(g, name)?;
    let shape = ds.shape();
    if shape.len() != 2 || shape[1] != C || len.is_some_and(|n| n != shape[0]) {
        return Err(Fail(format!(
            "dataset `{}/{name}` has shape {shape:?}, expected ({}, {C})",
            g.name(),
            len.map_or("n".into(), |n| n.to_string())
        )));
    }
    let raw = ds
        .read_raw::<T>()
        .map_err(|e| Fail(format!("dataset `{}/{name}`: {e}", g.name())))?;
    if raw.len() != shape[0] * C {
        return Err(Fail(format!("dataset `{}/{name}` is short", g.name())));
    }
    Ok(raw
        .chunks_exact(C)
        .map(|c| {
            let mut row = [T::default(); C];
            row.copy_from_slice(c);
            row
        })
        .collect())
}

/// `file` if its root attribute `format` is `expected`; otherwise an input error naming
/// `path` and saying what the file is (another grainstat file, or no grainstat file at all).
pub(crate) fn require_format(
    file: hdf5::File,
    path: &Path,
    expected: &str,
    kind: &str,
) -> Result<hdf5::File, Error> {
    let format = file
        .attr("format")
        .and_then(|a| a.read_scalar::<VarLenUnicode>())
        .map(|s| s.as_str().to_owned());
    match format {
        Ok(f) if f == expected => Ok(file),
        Ok(f) => match f.strip_prefix("grainstat-") {
            Some(other) => Err(input_error(
                path,
                format!("is a grainstat {other} file, not a {kind} file"),
            )),
            None => Err(input_error(
                path,
                format!("not a grainstat {kind} file (format `{f}`)"),
            )),
        },
        Err(_) => Err(input_error(
            path,
            format!("not a grainstat {kind} file (no `format` attribute)"),
        )),
    }
}
