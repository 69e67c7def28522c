//! What comes from Python, checked at the boundary (pairs, orientations, axes: their types,
//! shapes and values, NaN refused), and what goes back (numpy columns, dicts).

use crate::arg_err;
use numpy::prelude::*;
use numpy::{PyArray1, PyArray2, PyUntypedArray};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyString};
use spherestep::model::geometry::{orientation_from_xyzw, unit, xyzw};
use spherestep::{parse_pairs, Orientation, Pair, UnitVec};

/// A short picture of a Python value for messages (its repr, cut at 60 characters).
pub fn shown(obj: &Bound<'_, PyAny>) -> String {
    let text = obj
        .repr()
        .map(|r| r.to_string())
        .unwrap_or_else(|_| "<unprintable>".into());
    match text.char_indices().nth(60) {
        Some((k, _)) => format!("{}...", &text[..k]),
        None => text,
    }
}

/// The shape of a numpy array, as numpy prints it: `(3, 1)`.
fn shape_text(shape: &[usize]) -> String {
    match shape {
        [n] => format!("({n},)"),
        s => format!(
            "({})",
            s.iter()
                .map(|n| n.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// `N` numbers from a sequence (a list, a tuple, a numpy array of shape `(N,)`), or what was
/// expected instead: `form` names the numbers (`x,y,z`). Values are not checked here.
pub fn numbers<const N: usize>(
    obj: &Bound<'_, PyAny>,
    arg: &str,
    form: &str,
) -> PyResult<[f64; N]> {
    let expected = |got: String| arg_err(arg, format!("{N} numbers {form}, got {got}"));
    if obj.is_instance_of::<PyString>() {
        return Err(expected(format!("the text {}", shown(obj))));
    }
    if let Ok(a) = obj.cast::<PyUntypedArray>() {
        if a.shape() != [N] {
            return Err(expected(format!(
                "an array of shape {}",
                shape_text(a.shape())
            )));
        }
    }
    let items: Vec<Bound<'_, PyAny>> = match obj.try_iter() {
        Ok(it) => it
            .collect::<PyResult<_>>()
            .map_err(|_| expected(shown(obj)))?,
        Err(_) => return Err(expected(shown(obj))),
    };
    if items.len() != N {
        return Err(expected(format!("{} values: {}", items.len(), shown(obj))));
    }
    let mut out = [0.0; N];
    for (o, item) in out.iter_mut().zip(&items) {
        // A number, not a nested sequence (a numpy array of one element converts to a float).
        if item.cast::<PyUntypedArray>().is_ok_and(|a| a.ndim() > 0) {
            return Err(expected(shown(obj)));
        }
        *o = item.extract::<f64>().map_err(|_| expected(shown(obj)))?;
    }
    Ok(out)
}

/// An orientation `qx, qy, qz, qw` (normalised; zero, infinite and NaN refused).
pub fn orientation(obj: &Bound<'_, PyAny>, arg: &str) -> PyResult<Orientation> {
    let [x, y, z, w] = numbers::<4>(obj, arg, "qx,qy,qz,qw")?;
    orientation_from_xyzw(x, y, z, w).ok_or_else(|| {
        arg_err(
            arg,
            format!("a non-zero, finite quaternion qx,qy,qz,qw, got [{x}, {y}, {z}, {w}]"),
        )
    })
}

/// An optional orientation, identity when `None`.
pub fn orientation_or_identity(obj: Option<&Bound<'_, PyAny>>, arg: &str) -> PyResult<Orientation> {
    match obj {
        Some(o) if !o.is_none() => orientation(o, arg),
        _ => Ok(Orientation::identity()),
    }
}

/// An axis `x, y, z` (normalised; zero, infinite and NaN refused).
pub fn axis(obj: &Bound<'_, PyAny>, arg: &str) -> PyResult<UnitVec> {
    let [x, y, z] = numbers::<3>(obj, arg, "x,y,z")?;
    unit(nalgebra::Vector3::new(x, y, z)).ok_or_else(|| {
        arg_err(
            arg,
            format!("a non-zero, finite vector x,y,z, got [{x}, {y}, {z}]"),
        )
    })
}

/// An active set: text `coil:magnet,coil:magnet` (as the command line takes it), or a sequence
/// of `(coil, magnet)` pairs of integers >= 0 (lists, tuples, a numpy integer array of shape
/// `(n, 2)`). Not checked against a motor (see `Scenario::check_active`).
pub fn pairs(obj: &Bound<'_, PyAny>, arg: &str) -> PyResult<Vec<Pair>> {
    if let Ok(s) = obj.cast::<PyString>() {
        return parse_pairs(&s.to_cow()?, arg).map_err(crate::lib_err);
    }
    let expected = |got: String| {
        arg_err(
            arg,
            format!(
                "pairs as text 'coil:magnet,coil:magnet' or as a sequence of (coil, magnet) \
                 pairs of integers >= 0, got {got}"
            ),
        )
    };
    if let Ok(a) = obj.cast::<PyUntypedArray>() {
        if a.ndim() != 2 || a.shape()[1] != 2 {
            return Err(expected(format!(
                "an array of shape {}",
                shape_text(a.shape())
            )));
        }
    }
    let Ok(items) = obj.try_iter() else {
        return Err(expected(shown(obj)));
    };
    let mut out = Vec::new();
    for (k, item) in items.enumerate() {
        let item = item?;
        let bad = || expected(format!("{} as pair {k}", shown(&item)));
        if item.is_instance_of::<PyString>() {
            return Err(bad());
        }
        let v: Vec<Bound<'_, PyAny>> = match item.try_iter() {
            Ok(it) => it.collect::<PyResult<_>>().map_err(|_| bad())?,
            Err(_) => return Err(bad()),
        };
        let [c, m] = v.as_slice() else {
            return Err(bad());
        };
        let index = |x: &Bound<'_, PyAny>| x.extract::<usize>().map_err(|_| bad());
        out.push(Pair::new(index(c)?, index(m)?));
    }
    if out.is_empty() {
        return Err(expected("no pairs".into()));
    }
    Ok(out)
}

/// Pairs as Python sees them: a list of `(coil, magnet)` tuples.
pub fn pair_tuples(pairs: &[Pair]) -> Vec<(usize, usize)> {
    pairs.iter().map(|p| (p.coil.0, p.magnet.0)).collect()
}

/// An orientation as numpy `[qx, qy, qz, qw]` (qw >= 0, as the files write it).
pub fn q_array<'py>(py: Python<'py>, q: &Orientation) -> Bound<'py, PyArray1<f64>> {
    PyArray1::from_vec(py, xyzw(q).to_vec())
}

/// Orientations as a numpy array of shape `(n, 4)`, rows `[qx, qy, qz, qw]`.
pub fn q_rows<'py, 'a>(
    py: Python<'py>,
    qs: impl ExactSizeIterator<Item = &'a Orientation>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let n = qs.len();
    let flat: Vec<f64> = qs.flat_map(xyzw).collect();
    PyArray1::from_vec(py, flat).reshape([n, 4])
}

/// A column of numbers as a read-only numpy array.
pub fn column<'py, T: numpy::Element>(py: Python<'py>, v: Vec<T>) -> Bound<'py, PyArray1<T>> {
    PyArray1::from_vec(py, v)
}

/// A JSON value (a summary as `--json` prints it) as Python objects: dicts, lists, numbers
/// (exactly the library's `f64`s), strings, `None`.
pub fn json_to_py<'py>(py: Python<'py>, v: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    use serde_json::Value;
    Ok(match v {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => b.into_pyobject(py)?.to_owned().into_any(),
        Value::Number(n) => match (n.as_u64(), n.as_i64()) {
            (Some(u), _) => u.into_pyobject(py)?.into_any(),
            (None, Some(i)) => i.into_pyobject(py)?.into_any(),
            _ => n.as_f64().unwrap_or(f64::NAN).into_pyobject(py)?.into_any(),
        },
        Value::String(s) => s.into_pyobject(py)?.into_any(),
        Value::Array(a) => {
            let list = PyList::empty(py);
            for x in a {
                list.append(json_to_py(py, x)?)?;
            }
            list.into_any()
        }
        Value::Object(o) => {
            let d = PyDict::new(py);
            for (k, x) in o {
                d.set_item(k, json_to_py(py, x)?)?;
            }
            d.into_any()
        }
    })
}

/// A summary (any of the library's serialisable summaries) as a Python dict, its keys those of
/// the command line's `--json`.
pub fn summary_dict<'py, S: serde::Serialize>(
    py: Python<'py>,
    s: &S,
) -> PyResult<Bound<'py, PyAny>> {
    let v = serde_json::to_value(s)
        .map_err(|e| crate::lib_err(spherestep::Error::json("the summary", e)))?;
    json_to_py(py, &v)
}
