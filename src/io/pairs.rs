//! The text form of an active set, `coil:magnet,coil:magnet` (0-based; `;` separates too), as
//! arguments (`--pairs`) and files (a plan's `active` column, `settle --sets`) write it: read
//! here, in the file and argument layer, so that the model's geometry needs no error type of
//! the command line (it writes a [`Pair`] with `Display` and reads one with `FromStr`).

use crate::error::{Error, Result};
use crate::model::geometry::Pair;

/// Parses an active set written `coil:magnet,coil:magnet` (0-based) or with `;` separators.
pub fn parse_pairs(text: &str, arg: &str) -> Result<Vec<Pair>> {
    let bad = |what: &str| Error::Arg {
        arg: arg.into(),
        expected: format!("pairs written coil:magnet,coil:magnet (0-based integers), {what}"),
    };
    let mut out = Vec::new();
    if text.trim().is_empty() {
        return Err(bad("got nothing"));
    }
    for item in text.split([',', ';']) {
        let item = item.trim();
        if item.is_empty() {
            return Err(bad(&format!(
                "got an empty pair in '{text}' (a stray ',' or ';')"
            )));
        }
        out.push(item.parse().map_err(|()| bad(&format!("got '{item}'")))?);
    }
    if out.is_empty() {
        return Err(bad("got nothing"));
    }
    Ok(out)
}
