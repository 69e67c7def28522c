//! The README and the book (`docs/*.md`) against the program:
//!
//! - every code block marked `sh` is run, in order, file by file, in a scratch folder holding a
//!   copy of `scenarios/` (where the outputs land), with `spherestep` and
//!   `cargo run --release --` both meaning the built binary, and must exit 0; blocks marked
//!   `sh,manual` (long studies, hardware, the test command itself) and `text` are not run;
//! - every code block says what it is (`sh`, `sh,manual`, `text`, `toml`, `rust`, ...), so that no
//!   unmarked block is taken for Rust by the doc tests;
//! - every relative link points at a file of the repository, and a `#anchor` into a Markdown
//!   file at one of its headings;
//! - every `toml` block is a scenario the parser accepts, and the README's main job prints the
//!   summary the README shows;
//! - the scenario reference (`docs/scenario-format.md`) lists exactly the keys the scenario
//!   parser's structs accept.

mod common;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// The code blocks' info strings the docs may use.
const KNOWN_INFO: &[&str] = &[
    "sh",
    "sh,manual",
    "text",
    "toml",
    "rust",
    "rust,ignore",
    "python",
    "csv",
    "json",
];

/// The README and the book's chapters, README first.
fn doc_files() -> Vec<PathBuf> {
    let root = Path::new(ROOT);
    let mut files: Vec<PathBuf> = std::fs::read_dir(root.join("docs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    files.sort();
    files.insert(0, root.join("README.md"));
    files
}

fn rel(p: &Path) -> String {
    p.strip_prefix(ROOT).unwrap().display().to_string()
}

/// A fenced code block: its first line's number, its info string and its text.
struct Block {
    line: usize,
    info: String,
    text: String,
}

/// The fenced code blocks of a Markdown text, and the text outside them (code lines blanked).
fn split(md: &str) -> (Vec<Block>, String) {
    let mut blocks = Vec::new();
    let mut prose = String::new();
    let mut open: Option<Block> = None;
    for (i, line) in md.lines().enumerate() {
        if let Some(rest) = line.strip_prefix("```") {
            match open.take() {
                None => {
                    open = Some(Block {
                        line: i + 1,
                        info: rest.trim().to_string(),
                        text: String::new(),
                    })
                }
                Some(b) => blocks.push(b),
            }
            prose.push('\n');
            continue;
        }
        match open.as_mut() {
            Some(b) => {
                b.text.push_str(line);
                b.text.push('\n');
                prose.push('\n');
            }
            None => {
                prose.push_str(line);
                prose.push('\n');
            }
        }
    }
    assert!(open.is_none(), "a code block is not closed");
    (blocks, prose)
}

/// What the shell blocks run with: `spherestep` and `cargo run --release --` are the binary.
const PRELUDE: &str = r#"
spherestep() { "$SPHERESTEP_BIN" "$@"; }
cargo() {
    if [ "$1" = run ] && [ "$2" = --release ] && [ "$3" = -- ]; then
        shift 3; "$SPHERESTEP_BIN" "$@"
    else
        echo "the docs test runs only 'cargo run --release --', not: cargo $*" >&2; return 1
    fi
}
"#;

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let target = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &target);
        } else {
            std::fs::copy(e.path(), &target).unwrap();
        }
    }
}

/// A scratch folder like the repository's root for the commands: the scenarios, and the
/// folders of docs/ that commands write into.
fn scratch() -> tempfile::TempDir {
    let t = tempfile::tempdir().unwrap();
    copy_dir(
        &Path::new(ROOT).join("scenarios"),
        &t.path().join("scenarios"),
    );
    for d in ["docs/wells", "docs/closed-loop"] {
        std::fs::create_dir_all(t.path().join(d)).unwrap();
    }
    t
}

#[test]
fn every_code_block_says_what_it_is() {
    for f in doc_files() {
        let (blocks, _) = split(&std::fs::read_to_string(&f).unwrap());
        for b in blocks {
            assert!(
                KNOWN_INFO.contains(&b.info.as_str()),
                "{}:{}: a code block marked {:?}; mark it as one of {:?}",
                rel(&f),
                b.line,
                b.info,
                KNOWN_INFO
            );
        }
    }
}

#[test]
fn the_shell_commands_run() {
    let started = Instant::now();
    let mut ran = 0;
    for f in doc_files() {
        let (blocks, _) = split(&std::fs::read_to_string(&f).unwrap());
        let blocks: Vec<Block> = blocks.into_iter().filter(|b| b.info == "sh").collect();
        if blocks.is_empty() {
            continue;
        }
        let dir = scratch();
        for b in blocks {
            let t = Instant::now();
            let out = Command::new("bash")
                .arg("-e")
                .arg("-o")
                .arg("pipefail")
                .arg("-c")
                .arg(format!("{PRELUDE}\n{}", b.text))
                .current_dir(dir.path())
                .env("SPHERESTEP_BIN", env!("CARGO_BIN_EXE_spherestep"))
                .output()
                .unwrap();
            assert!(
                out.status.success(),
                "{}:{}: the block failed ({}):\n{}\nstdout:\n{}\nstderr:\n{}",
                rel(&f),
                b.line,
                out.status,
                b.text,
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            );
            eprintln!("{}:{}: {:.1} s", rel(&f), b.line, t.elapsed().as_secs_f64());
            ran += 1;
        }
    }
    assert!(ran >= 10, "only {ran} shell blocks ran");
    eprintln!("{ran} blocks in {:.1} s", started.elapsed().as_secs_f64());
}

/// The heading anchors of a Markdown text, as mdBook and GitHub make them: lower case, spaces to
/// `-`, letters, digits, `-` and `_` kept, everything else dropped.
fn anchors(md: &str) -> BTreeSet<String> {
    let (_, prose) = split(md);
    prose
        .lines()
        .filter_map(|l| {
            let t = l.trim_start_matches('#');
            (t.len() < l.len() && t.starts_with(' ')).then_some(t.trim())
        })
        .map(|h| {
            h.to_lowercase()
                .chars()
                .filter_map(|c| match c {
                    ' ' => Some('-'),
                    c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
                    _ => None,
                })
                .collect()
        })
        .collect()
}

/// The targets of the Markdown links and images of a text outside code (blocks and spans).
fn link_targets(prose: &str) -> Vec<String> {
    let mut out = Vec::new();
    for line in prose.lines() {
        // Inline code spans hold no links.
        let mut plain = String::new();
        for (i, part) in line.split('`').enumerate() {
            if i % 2 == 0 {
                plain.push_str(part);
            }
        }
        let mut rest = plain.as_str();
        while let Some(k) = rest.find("](") {
            let after = &rest[k + 2..];
            let Some(end) = after.find(')') else { break };
            out.push(after[..end].to_string());
            rest = &after[end..];
        }
    }
    out
}

#[test]
fn the_links_point_at_files() {
    let mut bad = Vec::new();
    for f in doc_files() {
        let md = std::fs::read_to_string(&f).unwrap();
        let (_, prose) = split(&md);
        for target in link_targets(&prose) {
            if target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            let (path, anchor) = match target.split_once('#') {
                Some((p, a)) => (p, Some(a)),
                None => (target.as_str(), None),
            };
            let file = if path.is_empty() {
                f.clone()
            } else {
                f.parent().unwrap().join(path)
            };
            let Ok(file) = file.canonicalize() else {
                bad.push(format!("{}: {target}: no such file", rel(&f)));
                continue;
            };
            if let Some(a) = anchor {
                if file.extension().is_some_and(|x| x == "md") {
                    let text = std::fs::read_to_string(&file).unwrap();
                    if !anchors(&text).contains(a) {
                        bad.push(format!("{}: {target}: no heading #{a}", rel(&f)));
                    }
                }
            }
        }
    }
    assert!(bad.is_empty(), "broken links:\n{}", bad.join("\n"));
}

/// The field names of `struct NAME { ... }` in a source text; the struct must refuse unknown
/// keys and rename none.
fn fields(source: &str, file: &str, name: &str) -> Vec<String> {
    let start = source
        .find(&format!("struct {name} {{"))
        .unwrap_or_else(|| panic!("{file}: no struct {name}"));
    let attrs = &source[source[..start].rfind("#[derive").unwrap()..start];
    assert!(
        attrs.contains("deny_unknown_fields"),
        "{file}: {name} does not refuse unknown keys"
    );
    let body = &source[start..start + source[start..].find("\n}").unwrap()];
    assert!(
        !body.contains("rename") && !body.contains("alias") && !body.contains("flatten"),
        "{file}: {name} renames a field: the docs test reads the field names as the keys"
    );
    body.lines()
        .skip(1)
        .filter_map(|l| {
            let l = l.trim();
            let l = l
                .strip_prefix("pub(super) ")
                .or_else(|| l.strip_prefix("pub "))
                .unwrap_or(l);
            let (field, _) = l.split_once(':')?;
            (!field.is_empty()
                && field
                    .chars()
                    .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_'))
            .then(|| field.to_string())
        })
        .collect()
}

/// Every key the scenario parser accepts, as `section.key` (`relay.boards.port` for the
/// entries of `[[relay.boards]]`).
fn parser_keys() -> BTreeSet<String> {
    let read = |p: &str| std::fs::read_to_string(Path::new(ROOT).join(p)).unwrap();
    let raw = read("src/io/scenario/raw.rs");
    let relay = read("src/relay/config.rs");
    let boards = read("src/relay/boards.rs");
    let sensor = read("src/io/sensor_section.rs");
    let sections: &[(&str, &str, &str, &str)] = &[
        ("rotor", &raw, "src/io/scenario/raw.rs", "RawPacking"),
        ("stator", &raw, "src/io/scenario/raw.rs", "RawPacking"),
        ("magnets", &raw, "src/io/scenario/raw.rs", "RawMagnets"),
        ("body", &raw, "src/io/scenario/raw.rs", "RawBody"),
        ("settle", &raw, "src/io/scenario/raw.rs", "RawSettle"),
        ("plan", &raw, "src/io/scenario/raw.rs", "RawPlan"),
        ("sweep", &raw, "src/io/scenario/raw.rs", "RawSweep"),
        ("report", &raw, "src/io/scenario/raw.rs", "RawReport"),
        ("relay", &relay, "src/relay/config.rs", "RelayConfig"),
        (
            "relay.boards",
            &boards,
            "src/relay/boards.rs",
            "BoardConfig",
        ),
        ("sensor", &sensor, "src/io/sensor_section.rs", "RawSensor"),
    ];
    let mut keys = BTreeSet::new();
    let mut top_sections = BTreeSet::new();
    for field in fields(&raw, "src/io/scenario/raw.rs", "RawScenario") {
        if sections.iter().any(|(s, ..)| *s == field) {
            top_sections.insert(field);
        } else {
            keys.insert(field);
        }
    }
    let expected: BTreeSet<String> = sections
        .iter()
        .filter(|(s, ..)| !s.contains('.'))
        .map(|(s, ..)| s.to_string())
        .collect();
    assert_eq!(
        top_sections, expected,
        "RawScenario's sections changed: say in tests/docs.rs which struct parses each"
    );
    for (section, source, file, name) in sections {
        for f in fields(source, file, name) {
            keys.insert(format!("{section}.{f}"));
        }
    }
    keys
}

/// The keys of the scenario reference's tables: the `code` names in each row's first cell.
fn documented_keys() -> BTreeSet<String> {
    let md = std::fs::read_to_string(Path::new(ROOT).join("docs/scenario-format.md")).unwrap();
    let mut keys = BTreeSet::new();
    for line in md.lines() {
        let Some(row) = line.strip_prefix('|') else {
            continue;
        };
        let first = row.split('|').next().unwrap();
        for (i, part) in first.split('`').enumerate() {
            if i % 2 == 1 {
                keys.insert(part.to_string());
            }
        }
    }
    keys
}

#[test]
fn the_scenario_reference_lists_every_key_the_parser_accepts() {
    let parser = parser_keys();
    let docs = documented_keys();
    let undocumented: Vec<_> = parser.difference(&docs).collect();
    let unknown: Vec<_> = docs.difference(&parser).collect();
    assert!(
        undocumented.is_empty() && unknown.is_empty(),
        "docs/scenario-format.md against the parser:\n  accepted but not documented: \
         {undocumented:?}\n  documented but not accepted: {unknown:?}"
    );
    assert!(parser.len() > 80, "only {} keys found", parser.len());
}

#[test]
fn the_toml_blocks_are_scenarios_the_parser_accepts() {
    let mut checked = 0;
    for f in doc_files() {
        let (blocks, _) = split(&std::fs::read_to_string(&f).unwrap());
        for b in blocks.iter().filter(|b| b.info == "toml") {
            let dir = tempfile::tempdir().unwrap();
            let file = dir.path().join("block.toml");
            std::fs::write(&file, &b.text).unwrap();
            if let Err(e) = spherestep::Scenario::load(&file) {
                panic!("{}:{}: not a scenario: {e}\n{}", rel(&f), b.line, b.text);
            }
            checked += 1;
        }
    }
    assert!(checked >= 3, "only {checked} TOML blocks");
}

/// The README's main job prints the summary the README shows below it.
#[test]
fn the_main_job_prints_what_the_readme_shows() {
    let md = std::fs::read_to_string(Path::new(ROOT).join("README.md")).unwrap();
    let (blocks, _) = split(&md);
    let job = blocks
        .iter()
        .position(|b| b.info == "sh")
        .expect("a sh block");
    let shown = blocks[job + 1..]
        .iter()
        .find(|b| b.info == "text")
        .expect("its output, in a text block");
    let dir = scratch();
    let out = Command::new("bash")
        .arg("-e")
        .arg("-c")
        .arg(format!("{PRELUDE}\n{}", blocks[job].text))
        .current_dir(dir.path())
        .env("SPHERESTEP_BIN", env!("CARGO_BIN_EXE_spherestep"))
        .output()
        .unwrap();
    assert!(out.status.success());
    let printed = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        printed.trim(),
        shown.text.trim(),
        "README.md:{}: the main job's summary changed",
        shown.line
    );
}

/// The relative `src="..."` and `href="..."` targets of an HTML page (no scheme, no page-local
/// `#anchor`, no `mailto:`), without their `#fragment` or `?query`.
fn html_targets(html: &str) -> Vec<String> {
    let mut out = Vec::new();
    for attr in ["src=\"", "href=\""] {
        let mut rest = html;
        while let Some(i) = rest.find(attr) {
            rest = &rest[i + attr.len()..];
            let Some(end) = rest.find('"') else { break };
            let t = &rest[..end];
            let local = !(t.is_empty()
                || t.contains("://")
                || t.starts_with('#')
                || t.starts_with("mailto:")
                || t.starts_with("data:")
                || t.starts_with("javascript:"));
            if local {
                let t = t.split(['#', '?']).next().unwrap_or(t);
                if !t.is_empty() {
                    out.push(t.to_string());
                }
            }
        }
    }
    out
}

/// The book as mdbook builds it (pictures and files outside `docs/` copied in by
/// `docs/outside.py`): every picture and every relative link of every page resolves to a file
/// of the built book. Skipped, saying so, where mdbook is not installed (`.ci/run` installs it).
#[test]
fn the_built_book_shows_every_picture_and_resolves_every_link() {
    let installed = Command::new("mdbook").arg("--version").output();
    if !installed.is_ok_and(|o| o.status.success()) {
        eprintln!("skipped: mdbook is not installed (cargo install mdbook)");
        return;
    }
    // built where `mdbook build docs` puts it (docs/book, ignored by git): a build elsewhere
    // would copy that folder in as the book's own files
    let built = Command::new("mdbook")
        .arg("build")
        .arg(Path::new(ROOT).join("docs"))
        .output()
        .unwrap();
    let out = Path::new(ROOT).join("docs/book");
    assert!(
        built.status.success(),
        "{}",
        String::from_utf8_lossy(&built.stderr)
    );
    let pages: Vec<PathBuf> = common::files_below(&out)
        .into_iter()
        .filter(|p| p.extension().is_some_and(|x| x == "html"))
        .collect();
    // every chapter of the summary is a page
    assert!(pages.len() > 30, "{} pages", pages.len());
    let mut dead = Vec::new();
    let mut images = 0;
    for page in &pages {
        let html = std::fs::read_to_string(page).unwrap();
        images += html.matches("<img src=\"").count();
        let dir = page.parent().unwrap();
        for t in html_targets(&html) {
            if !dir.join(&t).exists() {
                let at = page.strip_prefix(&out).unwrap().display().to_string();
                dead.push(format!("{at}: {t}"));
            }
        }
    }
    assert!(
        dead.is_empty(),
        "dead links in the built book:\n{}",
        dead.join("\n")
    );
    // the pictures the chapters show are in it (results/ among them)
    assert!(images >= 13, "{images} pictures");
    assert!(out.join("_outside/results").is_dir());
}
