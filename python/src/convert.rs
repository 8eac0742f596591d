//! Between Python and Rust values: a dict as a TOML table, and Rust vectors as numpy arrays
//! that take over the vector's memory (no copy).

use ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};

/// A dict as a TOML table; `path` is the dotted key of `value`, for the error naming a value
/// TOML cannot hold.
pub fn toml_table(dict: &Bound<'_, PyDict>, path: &str) -> PyResult<toml::Table> {
    let mut table = toml::Table::new();
    for (key, value) in dict.iter() {
        let key: String = key
            .extract()
            .map_err(|_| PyTypeError::new_err(format!("key {key} in `{path}` is not a string")))?;
        let inner = match path {
            "" => key.clone(),
            _ => format!("{path}.{key}"),
        };
        // None leaves a key out: TOML has no null.
        if !value.is_none() {
            table.insert(key, toml_value(&value, &inner)?);
        }
    }
    Ok(table)
}

/// One Python value as TOML: bool, int, float (numpy's scalars too), str, dict, list or
/// tuple.
fn toml_value(value: &Bound<'_, PyAny>, path: &str) -> PyResult<toml::Value> {
    Ok(if value.is_instance_of::<PyBool>() {
        toml::Value::Boolean(value.extract()?)
    } else if value.is_instance_of::<PyInt>() {
        toml::Value::Integer(value.extract()?)
    } else if value.is_instance_of::<PyFloat>() {
        toml::Value::Float(value.extract()?)
    } else if value.is_instance_of::<PyString>() {
        toml::Value::String(value.extract()?)
    } else if let Ok(dict) = value.cast::<PyDict>() {
        toml::Value::Table(toml_table(dict, path)?)
    } else if value.is_instance_of::<PyList>() || value.is_instance_of::<PyTuple>() {
        let items = value.try_iter()?.enumerate().map(|(i, item)| {
            let item = item?;
            toml_value(&item, &format!("{path}[{i}]"))
        });
        toml::Value::Array(items.collect::<PyResult<_>>()?)
    } else if let Ok(v) = value.extract::<i64>() {
        // numpy's integers and others with `__index__`.
        toml::Value::Integer(v)
    } else if let Ok(v) = value.extract::<f64>() {
        toml::Value::Float(v)
    } else {
        return Err(PyTypeError::new_err(format!(
            "`{path}` is a {}, which a TOML file cannot hold",
            value.get_type().name()?
        )));
    })
}

/// A vector as a 1-D numpy array, without a copy.
pub fn array1<'py, T: numpy::Element>(py: Python<'py>, v: Vec<T>) -> Bound<'py, PyArray1<T>> {
    v.into_pyarray(py)
}

/// Rows of two as an `(n, 2)` numpy array, without a copy.
pub fn array2<'py, T: numpy::Element>(
    py: Python<'py>,
    rows: Vec<[T; 2]>,
) -> Bound<'py, PyArray2<T>> {
    let n = rows.len();
    let flat = rows.into_flattened();
    Array2::from_shape_vec((n, 2), flat)
        .expect("n rows of 2")
        .into_pyarray(py)
}

/// A 2x2 tensor as a `(2, 2)` numpy array.
pub fn tensor<'py>(py: Python<'py>, t: [[f64; 2]; 2]) -> Bound<'py, PyArray2<f64>> {
    array2(py, t.to_vec())
}

/// 2x2 tensors as an `(n, 2, 2)` numpy array, without a copy.
pub fn tensors<'py>(py: Python<'py>, ts: Vec<[[f64; 2]; 2]>) -> Bound<'py, PyArray3<f64>> {
    let n = ts.len();
    let flat = ts.into_flattened().into_flattened();
    Array3::from_shape_vec((n, 2, 2), flat)
        .expect("n tensors of 2x2")
        .into_pyarray(py)
}

/// Rows of `width` values as an `(n, width)` numpy array (one copy into one block); `name`
/// names the table in the error where a row is not that wide.
pub fn table<'py>(
    py: Python<'py>,
    name: &str,
    rows: &[Vec<f64>],
    width: usize,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let flat: Vec<f64> = rows.iter().flatten().copied().collect();
    let array = Array2::from_shape_vec((rows.len(), width), flat).map_err(|_| {
        crate::FileError::new_err(format!("`{name}` has rows of other widths than {width}"))
    })?;
    Ok(array.into_pyarray(py))
}
