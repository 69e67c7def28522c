//! The folder-level import graph of `src/`: which top-level module (a folder of `src/`, or a
//! file beside them: `error`, `serial`, `text`) uses which, from the `crate::...` paths outside
//! comments, string literals and unit tests. It must have no circle (docs/architecture.md,
//! "Which module imports which"); a circle fails naming the files that close it.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// `text` with comments, string and character literals blanked (newlines kept).
fn code_only(text: &str) -> String {
    let b = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    let blank = |out: &mut String, s: &[u8]| {
        for &c in s {
            out.push(if c == b'\n' { '\n' } else { ' ' });
        }
    };
    while i < b.len() {
        let rest = &b[i..];
        let end = if rest.starts_with(b"//") {
            rest.iter().position(|&c| c == b'\n').unwrap_or(rest.len())
        } else if rest.starts_with(b"/*") {
            text[i + 2..].find("*/").map_or(rest.len(), |k| k + 4)
        } else if rest.starts_with(b"r\"") || rest.starts_with(b"r#") {
            let hashes = rest[1..].iter().take_while(|&&c| c == b'#').count();
            let close = format!("\"{}", "#".repeat(hashes));
            let open = 1 + hashes + 1;
            text[i + open..]
                .find(&close)
                .map_or(rest.len(), |k| open + k + close.len())
        } else if rest[0] == b'"' {
            let mut k = 1;
            while k < rest.len() && rest[k] != b'"' {
                k += if rest[k] == b'\\' { 2 } else { 1 };
            }
            (k + 1).min(rest.len())
        } else if rest[0] == b'\'' && rest.len() > 2 && (rest[2] == b'\'' || rest[1] == b'\\') {
            // a character literal ('x', '\n', '\u{..}'), not a lifetime
            let k = rest[2..]
                .iter()
                .position(|&c| c == b'\'')
                .map_or(1, |k| k + 3);
            k.min(rest.len())
        } else {
            out.push(rest[0] as char);
            i += 1;
            continue;
        };
        blank(&mut out, &rest[..end]);
        i += end;
    }
    out
}

/// `code` without the items under `#[cfg(test)]` (a `mod tests { ... }`, or one item).
fn without_tests(code: &str) -> String {
    let mut out = code.to_string();
    while let Some(at) = out.find("#[cfg(test)]") {
        let after = at + "#[cfg(test)]".len();
        let body = &out[after..];
        let (open, semi) = (body.find('{'), body.find(';'));
        let end = match (open, semi) {
            (Some(o), Some(s)) if s < o => after + s + 1,
            (Some(o), _) => {
                let mut depth = 0;
                let mut end = out.len();
                for (k, c) in out[after + o..].char_indices() {
                    match c {
                        '{' => depth += 1,
                        '}' => {
                            depth -= 1;
                            if depth == 0 {
                                end = after + o + k + 1;
                                break;
                            }
                        }
                        _ => {}
                    }
                }
                end
            }
            (None, Some(s)) => after + s + 1,
            (None, None) => out.len(),
        };
        out.replace_range(at..end, "");
    }
    out
}

/// The top-level modules a file's code names through `crate::`.
fn used_modules(code: &str) -> BTreeSet<String> {
    let mut used = BTreeSet::new();
    let ident = |s: &str| -> String {
        s.trim_start()
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect()
    };
    for (k, _) in code.match_indices("crate::") {
        // not `spherestep::crate_x` nor `$crate::`
        let before = code[..k].chars().last();
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == '$') {
            continue;
        }
        let rest = &code[k + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            // `crate::{a::b, c}`: the first name of each top-level entry
            let mut depth = 0;
            let mut start = 0;
            for (j, c) in group.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => {
                        used.insert(ident(&group[start..j]));
                        break;
                    }
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        used.insert(ident(&group[start..j]));
                        start = j + 1;
                    }
                    _ => {}
                }
            }
        } else {
            used.insert(ident(rest));
        }
    }
    used.remove("");
    used
}

fn rust_files(dir: &Path) -> Vec<PathBuf> {
    crate::common::files_below(dir)
        .into_iter()
        .filter(|p| p.extension().is_some_and(|e| e == "rs"))
        .collect()
}

/// The folder-level graph of `src/`: module -> (module it uses -> the files that use it).
fn graph(src: &Path) -> BTreeMap<String, BTreeMap<String, BTreeSet<String>>> {
    let mut g: BTreeMap<String, BTreeMap<String, BTreeSet<String>>> = BTreeMap::new();
    for file in rust_files(src) {
        let rel = file.strip_prefix(src).unwrap();
        let first = rel
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy();
        let module = first.trim_end_matches(".rs").to_string();
        // the crate root re-exports every layer; the binary's files are above them all
        if module == "lib" || module == "main" {
            continue;
        }
        let text = std::fs::read_to_string(&file).unwrap();
        let code = without_tests(&code_only(&text));
        for used in used_modules(&code) {
            if used != module {
                let files = g
                    .entry(module.clone())
                    .or_default()
                    .entry(used)
                    .or_default();
                files.insert(rel.display().to_string());
            }
        }
    }
    g
}

/// A circle of the graph, if any: the modules in order, the first repeated at the end.
fn circle(g: &BTreeMap<String, BTreeMap<String, BTreeSet<String>>>) -> Option<Vec<String>> {
    fn visit(
        n: &str,
        g: &BTreeMap<String, BTreeMap<String, BTreeSet<String>>>,
        path: &mut Vec<String>,
        done: &mut BTreeSet<String>,
    ) -> Option<Vec<String>> {
        if let Some(k) = path.iter().position(|p| p == n) {
            let mut c = path[k..].to_vec();
            c.push(n.to_string());
            return Some(c);
        }
        if done.contains(n) {
            return None;
        }
        path.push(n.to_string());
        for next in g.get(n).into_iter().flat_map(|m| m.keys()) {
            if let Some(c) = visit(next, g, path, done) {
                return Some(c);
            }
        }
        path.pop();
        done.insert(n.to_string());
        None
    }
    let mut done = BTreeSet::new();
    g.keys()
        .find_map(|n| visit(n, g, &mut Vec::new(), &mut done))
}

#[test]
fn the_folders_of_src_import_each_other_in_no_circle() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let g = graph(&src);
    // the map, for docs/architecture.md (`-- --nocapture`)
    for (m, uses) in &g {
        eprintln!(
            "{m}: {}",
            uses.keys().cloned().collect::<Vec<_>>().join(", ")
        );
    }
    if let Some(c) = circle(&g) {
        let edges: Vec<String> = c
            .windows(2)
            .map(|w| format!("{} -> {} ({})", w[0], w[1], join(&g[&w[0]][&w[1]])))
            .collect();
        panic!(
            "the folders of src/ import each other in a circle:\n{}",
            edges.join("\n")
        );
    }
    // the map of docs/architecture.md, checked: each layer imports what it says, no more
    let uses = |m: &str| -> Vec<&str> {
        g.get(m)
            .map(|u| u.keys().map(String::as_str).collect())
            .unwrap_or_default()
    };
    assert_eq!(uses("model"), Vec::<&str>::new());
    assert_eq!(uses("serial"), Vec::<&str>::new());
    assert_eq!(uses("text"), Vec::<&str>::new());
    assert_eq!(uses("physics"), ["model", "text"]);
    assert_eq!(uses("planning"), ["model", "physics", "text"]);
    assert_eq!(uses("sensor"), ["model", "planning", "serial", "text"]);
    assert_eq!(uses("relay"), ["model", "planning", "serial", "text"]);
    assert_eq!(uses("rig"), ["model", "planning", "relay", "sensor"]);
    assert!(!uses("error").contains(&"io"), "{:?}", uses("error"));
}

fn join(files: &BTreeSet<String>) -> String {
    files.iter().cloned().collect::<Vec<_>>().join(", ")
}

#[test]
fn the_graph_sees_paths_in_code_only() {
    let code = code_only(
        "use crate::a::X; // crate::b\nlet s = \"crate::c\"; let c = '{';\n/* crate::d */ \
         use crate::{e::Y, f};\n#[cfg(test)]\nmod tests { use crate::g; }\n",
    );
    let used = used_modules(&without_tests(&code));
    assert_eq!(used, ["a", "e", "f"].map(String::from).into());
    // and a circle is found
    let mut g: BTreeMap<String, BTreeMap<String, BTreeSet<String>>> = BTreeMap::new();
    for (a, b) in [("x", "y"), ("y", "z"), ("z", "x")] {
        g.entry(a.into()).or_default().entry(b.into()).or_default();
    }
    assert_eq!(circle(&g).unwrap(), ["x", "y", "z", "x"]);
}
