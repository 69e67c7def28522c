//! `Scenario.replace`: keyword changes of a scenario's values, made to its TOML text and checked
//! again as a file is, each refusal naming the key as the caller wrote it.

use crate::convert::shown;
use crate::{arg_err, lib_err};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyString};
use std::path::Path;

/// One change: the key's path (`["body", "damping"]`), as the caller wrote it
/// (`"body.damping"`), and the new value (None: the key removed, its default).
pub struct Change {
    pub key: String,
    path: Vec<String>,
    value: Option<toml::Value>,
}

/// The changes `key = value` means: one, or one per entry of a dict value (a section).
pub fn flatten(key: &str, value: &Bound<'_, PyAny>, out: &mut Vec<Change>) -> PyResult<()> {
    let path: Vec<String> = key.split('.').map(str::to_string).collect();
    if path.iter().any(|p| p.is_empty()) {
        return Err(arg_err(
            key,
            "a key such as \"body.damping\" (a section and a key, joined by a dot)",
        ));
    }
    if let Ok(d) = value.cast::<PyDict>() {
        for (k, v) in d.iter() {
            let k: String = k
                .extract()
                .map_err(|_| arg_err(key, format!("keys as text, got {}", shown(&k))))?;
            flatten(&format!("{key}.{k}"), &v, out)?;
        }
        return Ok(());
    }
    let value = match value.is_none() {
        true => None,
        false => Some(toml_value(value, key)?),
    };
    out.push(Change {
        key: key.to_string(),
        path,
        value,
    });
    Ok(())
}

/// A Python value as TOML: a bool, a whole number, a number, text, or a sequence of them.
fn toml_value(v: &Bound<'_, PyAny>, key: &str) -> PyResult<toml::Value> {
    if v.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(v.extract()?));
    }
    if v.is_instance_of::<PyInt>() {
        let n: i64 = v.extract().map_err(|_| {
            arg_err(
                key,
                format!("a whole number within 64 bits, got {}", shown(v)),
            )
        })?;
        return Ok(toml::Value::Integer(n));
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(v.extract()?));
    }
    if v.is_instance_of::<PyString>() {
        return Ok(toml::Value::String(v.extract()?));
    }
    // numpy scalars: a whole number (it has __index__), else a number
    if let Ok(n) = v.call_method0("__index__").and_then(|i| i.extract::<i64>()) {
        return Ok(toml::Value::Integer(n));
    }
    if let Ok(x) = v.extract::<f64>() {
        return Ok(toml::Value::Float(x));
    }
    if let Ok(items) = v.try_iter() {
        let mut list = Vec::new();
        for item in items {
            list.push(toml_value(&item?, key)?);
        }
        return Ok(toml::Value::Array(list));
    }
    Err(arg_err(
        key,
        format!(
            "a value a scenario file can hold (a bool, a number, text, a list, a dict for a \
             section, None for the default), got {}",
            shown(v)
        ),
    ))
}

/// `text` with `changes` made: the new TOML text.
fn changed(text: &str, path: &Path, changes: &[Change]) -> PyResult<String> {
    let mut table: toml::Table = text.parse().map_err(|e: toml::de::Error| {
        lib_err(spherestep::Error::Parse {
            file: path.to_path_buf(),
            message: e.to_string().trim_end().to_string(),
        })
    })?;
    for c in changes {
        let (last, sections) = c.path.split_last().expect("a key has a name");
        let mut t = &mut table;
        for s in sections {
            let entry = t
                .entry(s.clone())
                .or_insert_with(|| toml::Value::Table(Default::default()));
            t = entry.as_table_mut().ok_or_else(|| {
                arg_err(
                    &c.key,
                    format!("a key of a section, but {s} is not a section"),
                )
            })?;
        }
        match &c.value {
            None => {
                t.remove(last);
            }
            Some(v) => {
                t.insert(last.clone(), v.clone());
            }
        }
    }
    toml::to_string(&table).map_err(|e| arg_err(&changes[0].key, e.to_string()))
}

/// The scenario of `text` (read from `path`) with `changes` made, checked: its text and the
/// scenario. A change the scenario refuses raises `spherestep.Error` naming its key (the first
/// refused alone; where each is allowed alone but not together, all of them).
pub fn apply(
    text: &str,
    path: &Path,
    changes: &[Change],
) -> PyResult<(String, spherestep::Scenario)> {
    let new = changed(text, path, changes)?;
    match spherestep::Scenario::from_toml(&new, path) {
        Ok(sc) => Ok((new, sc)),
        Err(e) => {
            for c in changes {
                let alone = changed(text, path, std::slice::from_ref(c))?;
                if let Err(e) = spherestep::Scenario::from_toml(&alone, path) {
                    return Err(arg_err(&c.key, refusal(e)));
                }
            }
            let keys: Vec<&str> = changes.iter().map(|c| c.key.as_str()).collect();
            Err(arg_err(&keys.join(", "), refusal(e)))
        }
    }
}

/// A scenario's refusal of a change, as what was expected: the parser's or the check's own
/// words, without the file (the changed text is not the file) and the parser's excerpt of a
/// text the caller never wrote.
fn refusal(e: spherestep::Error) -> String {
    let why = match e {
        spherestep::Error::Parse { message, .. } => {
            message.lines().last().unwrap_or_default().to_string()
        }
        spherestep::Error::Field {
            field, expected, ..
        } => format!("field `{field}`: expected {expected}"),
        other => other.to_string(),
    };
    format!("a key and a value the scenario accepts ({why})")
}
