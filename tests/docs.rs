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
//! - every `toml` block is a scenario the parser accepts;
//! - every sample of the program's output (a `text` block marked `<!-- output: NAME -->`) is
//!   what the program prints today, but for the parts its marker says vary; every other `text`
//!   block is a synopsis; `SPHERESTEP_BLESS=1` rewrites the samples;
//! - every option a synopsis names is one its command's `--help` lists;
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
    // the bench curve and the replay log docs/fit.md fits
    copy_dir(
        &Path::new(ROOT).join("assets/fit"),
        &t.path().join("assets/fit"),
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
        ("design", &raw, "src/io/scenario/raw.rs", "RawDesign"),
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

/// A sample output's marker: the HTML comment on the line before a `text` block,
/// `<!-- output: NAME (...); varies: `A{}B`, ... -->`. NAME says what prints it (a generator
/// below, or `python-errors`, which `python/tests/test_docs.py` checks); each `A{}B` is a part
/// that differs from run to run (a time, a pseudo-terminal's number): what lies between `A` and
/// the next `B` on a line is not compared.
struct Marker {
    name: String,
    varies: Vec<String>,
    /// `; numbers within T`: the numbers may differ by up to T (a ball whose last digits
    /// depend on the machine's timing).
    within: f64,
}

fn marker(md: &str, b: &Block) -> Option<Marker> {
    let before = md.lines().nth(b.line.checked_sub(2)?)?.trim();
    let body = before.strip_prefix("<!-- output:")?.strip_suffix("-->")?;
    let (body, within) = match body.split_once("; numbers within ") {
        Some((b, t)) => (b, t.trim().parse().expect("; numbers within T: a number")),
        None => (body, 0.0),
    };
    let (head, varies) = match body.split_once("; varies:") {
        Some((h, v)) => (h, v),
        None => (body, ""),
    };
    let name = head
        .split_whitespace()
        .next()
        .unwrap_or_default()
        .to_string();
    let varies = varies
        .split('`')
        .skip(1)
        .step_by(2)
        .map(str::to_string)
        .collect();
    Some(Marker {
        name,
        varies,
        within,
    })
}

/// A text cut into its numbers and the text between them.
fn tokens(text: &str) -> Vec<Result<f64, String>> {
    let mut out: Vec<Result<f64, String>> = Vec::new();
    let mut rest = text;
    while !rest.is_empty() {
        let number = rest
            .char_indices()
            .take_while(|&(i, c)| c.is_ascii_digit() || c == '.' || (i == 0 && c == '-'))
            .last()
            .map_or(0, |(i, c)| i + c.len_utf8());
        match rest[..number].parse::<f64>() {
            Ok(x) if rest[..number].bytes().any(|b| b.is_ascii_digit()) => {
                out.push(Ok(x));
                rest = &rest[number..];
            }
            _ => {
                let mut chars = rest.chars();
                let c = chars.next().unwrap_or_default();
                match out.last_mut() {
                    Some(Err(t)) => t.push(c),
                    _ => out.push(Err(c.to_string())),
                }
                rest = chars.as_str();
            }
        }
    }
    out
}

/// Whether two texts are the same but for numbers that differ by up to `within`.
fn same(a: &str, b: &str, within: f64) -> bool {
    if within == 0.0 {
        return a == b;
    }
    let (a, b) = (tokens(a), tokens(b));
    a.len() == b.len()
        && a.iter().zip(&b).all(|(x, y)| match (x, y) {
            (Ok(x), Ok(y)) => (x - y).abs() <= within,
            (Err(x), Err(y)) => x == y,
            _ => false,
        })
}

/// `text` with the varying parts `A{}B` of `varies` masked (the text between `A` and the next
/// `B` on its line made `{}`; an empty `B`: to the end of the line).
fn mask(text: &str, varies: &[String]) -> String {
    let mut lines: Vec<String> = text.trim_end().lines().map(str::to_string).collect();
    for pattern in varies {
        let (a, b) = pattern.split_once("{}").expect("a varying part A{}B");
        for line in &mut lines {
            let mut out = String::new();
            let mut rest = line.as_str();
            while let Some(i) = rest.find(a) {
                out.push_str(&rest[..i + a.len()]);
                rest = &rest[i + a.len()..];
                let end = if b.is_empty() {
                    rest.len()
                } else {
                    match rest.find(b) {
                        Some(j) => j,
                        None => break,
                    }
                };
                out.push_str("{}");
                rest = &rest[end..];
            }
            out.push_str(rest);
            *line = out;
        }
    }
    lines.join("\n")
}

/// Runs a `sh` block's text in `dir` (the docs' prelude first): its standard output.
fn run_sh(dir: &Path, text: &str) -> String {
    let out = Command::new("bash")
        .arg("-e")
        .arg("-o")
        .arg("pipefail")
        .arg("-c")
        .arg(format!("{PRELUDE}\n{text}"))
        .current_dir(dir)
        .env("SPHERESTEP_BIN", env!("CARGO_BIN_EXE_spherestep"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{text}\nfailed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The rehearsal of `docs/rehearse.md`'s "Two terminals", as a reader runs it: the main job's
/// plan, the virtual motor (numato, quat-csv, `--link-dir /tmp/motor`), the open-loop replay
/// with `--verify` on its port. What the virtual motor prints: its ports (to the `ready:`
/// line) and its summary. The link folder is a scratch one, shown as `/tmp/motor`.
fn rehearsal() -> (String, String) {
    use std::io::{BufRead, BufReader, Read};
    let dir = scratch();
    run_sh(
        dir.path(),
        "spherestep plan scenarios/prototype.toml --axis 0,1,0 --angle 90 --out plan.csv",
    );
    let links = dir.path().join("motor");
    let links_s = links.display().to_string();
    let mut v = Command::new(env!("CARGO_BIN_EXE_spherestep"))
        .args(["virtual", "scenarios/prototype.toml", "--board", "numato"])
        .args(["--sensor", "quat-csv", "--link-dir", &links_s])
        .args(["--log", "virtual.csv", "--plan", "plan.csv"])
        // a bound on the virtual clock: the rehearsal takes about 15 s
        .args(["--max-seconds", "120"])
        .current_dir(dir.path())
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let mut out = BufReader::new(v.stdout.take().unwrap());
    let mut ports = String::new();
    while !ports.lines().last().unwrap_or("").starts_with("ready:") {
        let mut line = String::new();
        if out.read_line(&mut line).unwrap() == 0 {
            let _ = v.kill();
            panic!("the virtual motor ended before it was ready: {ports}");
        }
        ports.push_str(&line);
    }
    let board = format!("{links_s}/board0");
    let replay = Command::new(env!("CARGO_BIN_EXE_spherestep"))
        .args(["replay", "plan.csv", "scenarios/prototype.toml"])
        .args(["--board", "numato", "--port", &board, "--verify"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    let mut summary = String::new();
    out.read_to_string(&mut summary).unwrap();
    let status = v.wait().unwrap();
    assert!(
        replay.status.success() && status.success(),
        "the rehearsal failed: {}\n{summary}",
        String::from_utf8_lossy(&replay.stderr)
    );
    let shown = |t: &str| t.replace(&links_s, "/tmp/motor");
    (shown(&ports), shown(&summary))
}

/// What the command behind a sample prints today; `blocks` are the file's blocks, the sample
/// `blocks[k]`. Samples of the same generator in one file share one run (`cache`).
fn printed(name: &str, blocks: &[Block], k: usize, cache: &mut Option<(String, String)>) -> String {
    match name {
        // the stdout of the last `sh` block above the sample (README: the main job)
        "sh-above" => {
            let sh = blocks[..k]
                .iter()
                .rfind(|b| b.info == "sh")
                .expect("a sh block above the sample");
            run_sh(scratch().path(), &sh.text)
        }
        // `docs/replay.md`: the dry run of the plan in the `csv` block above
        "replay-dry-run" => {
            let csv = blocks[..k]
                .iter()
                .rfind(|b| b.info == "csv")
                .expect("a csv block (the plan) above the sample");
            let dir = scratch();
            std::fs::write(dir.path().join("plan.csv"), &csv.text).unwrap();
            run_sh(
                dir.path(),
                "spherestep replay plan.csv --board modbus --dry-run",
            )
        }
        "rehearsal-ports" => cache.get_or_insert_with(rehearsal).0.clone(),
        "rehearsal-summary" => cache.get_or_insert_with(rehearsal).1.clone(),
        other => panic!("no generator for the sample output {other:?} (tests/docs.rs)"),
    }
}

/// The samples `python/tests/test_docs.py` checks (Python's own errors).
const CHECKED_BY_PYTHON: &[&str] = &["python-errors", "python-replace-errors"];

/// Every sample of the program's output in the README and the book (a `text` block marked
/// `<!-- output: NAME -->`) is what the program prints today, but for the parts its marker
/// says vary. Every other `text` block is a synopsis (`spherestep ...`). With
/// `SPHERESTEP_BLESS=1` the samples are rewritten with what the program prints instead:
/// `SPHERESTEP_BLESS=1 cargo test --release --test docs sample_outputs`.
#[test]
fn the_sample_outputs_are_what_the_program_prints() {
    let bless = std::env::var_os("SPHERESTEP_BLESS").is_some_and(|v| v == "1");
    let (mut differ, mut samples) = (Vec::new(), 0);
    for f in doc_files() {
        let md = std::fs::read_to_string(&f).unwrap();
        let (blocks, _) = split(&md);
        let mut cache = None;
        let mut lines: Vec<String> = md.lines().map(str::to_string).collect();
        let mut rewritten = false;
        for (k, b) in blocks.iter().enumerate().rev() {
            if b.info != "text" {
                continue;
            }
            let Some(m) = marker(&md, b) else {
                assert!(
                    b.text.starts_with("spherestep "),
                    "{}:{}: a text block that is neither a synopsis (`spherestep ...`) nor a \
                     sample marked `<!-- output: NAME -->` (see tests/docs.rs)",
                    rel(&f),
                    b.line
                );
                continue;
            };
            samples += 1;
            if CHECKED_BY_PYTHON.contains(&m.name.as_str()) {
                let py = std::fs::read_to_string(Path::new(ROOT).join("python/tests/test_docs.py"))
                    .unwrap();
                assert!(
                    py.contains(&m.name),
                    "python/tests/test_docs.py checks no {}",
                    m.name
                );
                continue;
            }
            let now = printed(&m.name, &blocks, k, &mut cache);
            // blessed, every sample is what the program prints now, varying parts included
            if now.trim_end() == b.text.trim_end()
                || !bless && same(&mask(&now, &m.varies), &mask(&b.text, &m.varies), m.within)
            {
                continue;
            }
            if bless {
                let n = b.text.lines().count();
                lines.splice(
                    b.line..b.line + n,
                    now.trim_end().lines().map(str::to_string),
                );
                rewritten = true;
            } else {
                differ.push(format!(
                    "{}:{} ({}): the book shows\n{}\nthe program prints\n{}",
                    rel(&f),
                    b.line,
                    m.name,
                    b.text.trim_end(),
                    now.trim_end()
                ));
            }
        }
        if rewritten {
            std::fs::write(&f, lines.join("\n") + "\n").unwrap();
            eprintln!("rewrote the samples of {}", rel(&f));
        }
    }
    assert!(samples >= 5, "only {samples} samples");
    assert!(
        differ.is_empty(),
        "samples that differ from what the program prints (rewrite them with \
         SPHERESTEP_BLESS=1 cargo test --release --test docs sample_outputs):\n\n{}",
        differ.join("\n\n")
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

/// Every option a synopsis of the book names (a `text` block `spherestep COMMAND ...`) is one
/// the command has (its `--help` lists it): a synopsis may leave options out, never show one
/// that is gone or misspelt.
#[test]
fn the_synopses_name_options_the_commands_have() {
    let mut bad = Vec::new();
    let mut checked = 0;
    for f in doc_files() {
        let (blocks, _) = split(&std::fs::read_to_string(&f).unwrap());
        for b in blocks.iter().filter(|b| b.info == "text") {
            for line in b.text.lines().filter(|l| l.starts_with("spherestep ")) {
                let command = line.split_whitespace().nth(1).unwrap_or_default();
                let out = Command::new(env!("CARGO_BIN_EXE_spherestep"))
                    .args([command, "--help"])
                    .output()
                    .unwrap();
                let help = String::from_utf8_lossy(&out.stdout);
                assert!(out.status.success(), "{}:{}: {line}", rel(&f), b.line);
                // this line and the indented ones after it
                let rest = b.text[b.text.find(line).unwrap()..].lines().skip(1);
                let more = rest.take_while(|l| l.starts_with(' '));
                for l in std::iter::once(line).chain(more) {
                    for word in l.split(|c: char| !(c.is_ascii_alphanumeric() || c == '-')) {
                        let Some(name) = word.strip_prefix("--") else {
                            continue;
                        };
                        checked += 1;
                        if !help.contains(&format!("--{name} "))
                            && !help.contains(&format!("--{name}\n"))
                            && !help.contains(&format!("--{name}="))
                        {
                            bad.push(format!("{}:{}: {command} has no --{name}", rel(&f), b.line));
                        }
                    }
                }
            }
        }
    }
    assert!(checked > 50, "only {checked} options");
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}
