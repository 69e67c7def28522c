//! The tabular results (`Plan`, `Simulation`, `Run`, `SettleTable`, `Wells`) as a notebook
//! wants them: named columns in order, as a dict of lists (`to_dict`), a pandas `DataFrame`
//! (`to_pandas`, pandas imported only then) and an HTML table (`_repr_html_`, what Jupyter
//! shows for a result left at the end of a cell).

use pyo3::exceptions::PyImportError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyFloat, PySlice};

/// A result's columns, in order: each a numpy array (numbers, booleans) or a list (pairs,
/// texts), all of one length (the result's rows).
pub type Columns<'py> = Vec<(String, Bound<'py, PyAny>)>;

/// The most rows `_repr_html_` shows in full; a longer table shows its first and last
/// `HTML_ENDS` rows with a row of dots between.
const HTML_MAX_ROWS: usize = 60;
const HTML_ENDS: usize = 20;

/// Appends the four columns `{prefix}qx`, `{prefix}qy`, `{prefix}qz`, `{prefix}qw` of
/// orientations given as an array of shape `(rows, 4)` (views of its columns).
pub fn push_q<'py>(cols: &mut Columns<'py>, prefix: &str, q: &Bound<'py, PyAny>) -> PyResult<()> {
    let py = q.py();
    for (k, name) in ["qx", "qy", "qz", "qw"].iter().enumerate() {
        let col = q.get_item((PySlice::full(py), k))?;
        cols.push((format!("{prefix}{name}"), col));
    }
    Ok(())
}

/// A column as a Python list (a numpy array's `tolist()`: Python ints, floats and bools).
fn as_list<'py>(col: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    if col.hasattr("tolist")? {
        col.call_method0("tolist")
    } else {
        Ok(
            pyo3::types::PyList::new(col.py(), col.try_iter()?.collect::<PyResult<Vec<_>>>()?)?
                .into_any(),
        )
    }
}

/// The columns as a dict: column name -> list, in the columns' order.
pub fn to_dict<'py>(py: Python<'py>, cols: &Columns<'py>) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    for (name, col) in cols {
        d.set_item(name, as_list(col)?)?;
    }
    Ok(d)
}

/// The columns as a pandas `DataFrame` (numbers keep their numpy types: `step` int64, floats
/// float64, flags bool); pandas is imported here, and its absence is an `ImportError` saying
/// how to install it.
pub fn to_pandas<'py>(
    py: Python<'py>,
    what: &str,
    cols: &Columns<'py>,
) -> PyResult<Bound<'py, PyAny>> {
    let pandas = py.import("pandas").map_err(|e| {
        if e.is_instance_of::<PyImportError>(py) {
            PyImportError::new_err(format!(
                "{what}.to_pandas() needs pandas, which is not installed: pip install pandas \
                 ({})",
                e.value(py)
            ))
        } else {
            e
        }
    })?;
    let d = PyDict::new(py);
    for (name, col) in cols {
        // numpy arrays as they are (their dtypes), lists as lists (object columns)
        d.set_item(name, col)?;
    }
    let names: Vec<&str> = cols.iter().map(|(n, _)| n.as_str()).collect();
    let kwargs = PyDict::new(py);
    kwargs.set_item("columns", names)?;
    pandas.getattr("DataFrame")?.call((d,), Some(&kwargs))
}

/// `&`, `<`, `>`, `"` and `'` as HTML entities.
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#x27;"),
            c => out.push(c),
        }
    }
    out
}

/// One cell as text: floats with 6 significant digits (Python's `format(x, ".6g")`), None
/// empty, anything else its `str()`.
fn cell(x: &Bound<'_, PyAny>) -> PyResult<String> {
    if x.is_none() {
        Ok(String::new())
    } else if x.is_instance_of::<PyFloat>() {
        Ok(x.call_method1("__format__", (".6g",))?.extract()?)
    } else {
        Ok(x.str()?.to_cow()?.into_owned())
    }
}

/// The columns as an HTML table, every text escaped: `caption` above (the result's repr), a
/// header of the column names, one row per result row (its index in the first cell); a table
/// of more than 60 rows shows its first and last 20.
pub fn to_html(caption: &str, cols: &Columns<'_>) -> PyResult<String> {
    let lists = cols
        .iter()
        .map(|(_, c)| as_list(c))
        .collect::<PyResult<Vec<_>>>()?;
    let rows = match lists.first() {
        Some(l) => l.len()?,
        None => 0,
    };
    let mut h = String::from("<table class=\"spherestep\">\n");
    h.push_str(&format!("<caption>{}</caption>\n", escape(caption)));
    h.push_str("<thead><tr><th></th>");
    for (name, _) in cols {
        h.push_str(&format!("<th>{}</th>", escape(name)));
    }
    h.push_str("</tr></thead>\n<tbody>\n");
    let shown: Vec<Option<usize>> = if rows > HTML_MAX_ROWS {
        (0..HTML_ENDS)
            .map(Some)
            .chain(std::iter::once(None))
            .chain((rows - HTML_ENDS..rows).map(Some))
            .collect()
    } else {
        (0..rows).map(Some).collect()
    };
    for r in shown {
        match r {
            None => {
                h.push_str("<tr><th>&hellip;</th>");
                for _ in cols {
                    h.push_str("<td>&hellip;</td>");
                }
            }
            Some(r) => {
                h.push_str(&format!("<tr><th>{r}</th>"));
                for l in &lists {
                    h.push_str(&format!("<td>{}</td>", escape(&cell(&l.get_item(r)?)?)));
                }
            }
        }
        h.push_str("</tr>\n");
    }
    h.push_str("</tbody>\n</table>");
    Ok(h)
}
