//! Batch runs keep their files where they belong and their work when killed: a scenario name
//! must be a plain file name, runs sharing a folder never remove each other's temporary files
//! (only those of dead processes of this machine), and a sweep's finished cases are saved as
//! they end so that `--resume` continues a killed sweep.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::batch;

fn text(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// `batch INPUT --out OUT --resume`, which must succeed: its standard error.
fn resumed(input: &Path, out: &Path) -> String {
    let r = batch(&[
        input.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--resume",
    ]);
    let err = String::from_utf8_lossy(&r.stderr).into_owned();
    assert!(r.status.success(), "{err}");
    err
}

#[test]
fn scenario_names_must_be_plain_file_names() {
    let t = tempfile::tempdir().unwrap();
    let s = t.path().join("scen");
    std::fs::create_dir_all(&s).unwrap();
    let bad = [
        ("a.toml", "../escaped"),
        ("b.toml", "summary"),
        ("c.toml", "Timing"),
        ("d.toml", "sub/dir"),
        ("e.toml", ".hidden"),
        ("f.toml", "x.shard-0-of-2"),
        ("g.toml", ""),
    ];
    for (file, name) in bad {
        std::fs::write(
            s.join(file),
            format!("name = \"{name}\"\n[plan]\nangle_deg = 30\n"),
        )
        .unwrap();
    }
    std::fs::write(s.join("good.toml"), "[plan]\nangle_deg = 30\n").unwrap();
    let out = t.path().join("out");
    let r = batch(&[s.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1), "{err}");
    for (file, name) in bad {
        let line = err
            .lines()
            .find(|l| l.contains(&format!("scenario {}", s.join(file).display())))
            .unwrap_or_else(|| panic!("{file} not reported: {err}"));
        assert!(
            line.contains("field `name`") && line.contains(&format!("got \"{name}\"")),
            "{line}"
        );
    }
    assert!(
        !t.path().join("escaped.csv").exists(),
        "nothing outside --out"
    );
    assert!(out.join("good.csv").is_file());
    let summary = text(&out.join("summary.csv"));
    assert!(summary.starts_with("name,kind,"), "{summary}");
    assert_eq!(summary.lines().count(), 2, "{summary}");
    // --resume over the same folder still works.
    resumed(&s.join("good.toml"), &out);
}

/// The pid of a process that has ended.
fn dead_pid() -> u32 {
    let mut c = Command::new("true").spawn().unwrap();
    let pid = c.id();
    c.wait().unwrap();
    pid
}

#[test]
fn only_provably_stale_temporaries_are_removed() {
    let t = tempfile::tempdir().unwrap();
    let s = t.path().join("a.toml");
    std::fs::write(&s, "[plan]\nangle_deg = 30\n").unwrap();
    let out = t.path().join("out");
    let kept_dir = out.join("sweep-plans");
    std::fs::create_dir_all(&kept_dir).unwrap();
    let host = spherestep::io::output::host_tag();
    let dead = dead_pid();
    let temp = |dir: &Path, name: &str, host: &str, pid: u32| -> PathBuf {
        let p = spherestep::io::output::temp_path_of(&dir.join(name), host, pid);
        std::fs::write(&p, b"partial").unwrap();
        p
    };
    // Stale: a dead process of this machine (a CSV, a picture cut short while drawing, one in
    // a kept plans' folder).
    let stale = [
        temp(&out, "s001.csv", &host, dead),
        temp(&out, "s001-fig5.png", &host, dead),
        temp(&kept_dir, "case-0.csv", &host, dead),
    ];
    // Not provably stale: a live process (this test), another machine's, not our name.
    let live = [
        temp(&out, "s002.csv", &host, std::process::id()),
        temp(&out, "s003.csv", "other-node", dead),
    ];
    let foreign = out.join(".notes.tmp");
    std::fs::write(&foreign, b"mine").unwrap();
    let r = batch(&[s.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    for p in &stale {
        assert!(!p.exists(), "stale {} left", p.display());
    }
    for p in live.iter().chain([&foreign]) {
        assert!(p.exists(), "{} removed", p.display());
    }
    // No temporary of the run itself is left.
    let own = format!("{host}-");
    let left: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(&own) && !n.contains(&format!("-{}.", std::process::id())))
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

const SWEEP: &str = "[plan]\nangle_deg = 45\n[sweep]\naxes = \"sphere\"\naxis_count = 6\nschemes = [\"weighted\", \"search\"]\n";

/// Replaces the `max_axis_error_deg` of `case` in sweep CSV rows by `value`.
fn mark(rows: &str, case: usize, value: &str) -> String {
    rows.lines()
        .map(|l| {
            let mut f: Vec<String> = l.split(',').map(str::to_string).collect();
            if f[0] == case.to_string() {
                f[10] = value.to_string();
            }
            f.join(",") + "\n"
        })
        .collect()
}

/// The sweep row of a progress file's line (its checksum, the last field, left out).
fn row_of(line: &str) -> &str {
    line.rsplit_once(',').unwrap().0
}

/// The kept plans in a folder, by name.
fn kept_plans(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .map(|rd| {
            rd.map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    names.sort();
    names
}

#[test]
fn resume_continues_a_sweep_from_its_saved_cases() {
    let t = tempfile::tempdir().unwrap();
    let s = t.path().join("sw.toml");
    // kept plans show which cases were computed: a case taken from the progress file has none
    std::fs::write(&s, format!("{SWEEP}keep_plans = true\n")).unwrap();
    let full = t.path().join("full");
    let r = batch(&[s.to_str().unwrap(), "--out", full.to_str().unwrap()]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let expected = text(&full.join("sw.csv"));
    assert!(
        !full.join("sw.csv.progress").exists(),
        "removed once written"
    );
    let (header, rows) = expected.split_once('\n').unwrap();
    assert_eq!(rows.lines().count(), 12);

    // A run that cannot write its result (a folder in the way) keeps every finished case.
    let out = t.path().join("out");
    std::fs::create_dir_all(out.join("sw.csv").join("blocker")).unwrap();
    let r = batch(&[s.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(r.status.code(), Some(1));
    let progress = out.join("sw.csv.progress");
    let saved = text(&progress);
    // the `.hash` holds the scenario's content hash (the progress file's), then the result's
    // digest
    let hash = text(&full.join("sw.csv.hash"));
    let (first, saved_rows) = saved.split_once('\n').unwrap();
    assert_eq!(first, format!("hash {}", hash.lines().next().unwrap()));
    assert!(
        hash.lines().nth(1).unwrap().starts_with("sha256 "),
        "{hash}"
    );
    let mut sorted: Vec<&str> = saved_rows.lines().collect();
    sorted.sort_by_key(|l| l.split(',').next().unwrap().parse::<usize>().unwrap());
    let unchecked: Vec<&str> = sorted.iter().map(|l| row_of(l)).collect();
    assert_eq!(
        unchecked.join("\n") + "\n",
        rows,
        "every case saved, the same rows (each followed by its checksum)"
    );
    assert!(sorted
        .iter()
        .all(|l| l.rsplit_once(',').unwrap().1.len() == 64));

    // Killed half way: cases 0-5 saved, a torn row after them.
    std::fs::remove_dir_all(out.join("sw.csv")).unwrap();
    std::fs::remove_dir_all(out.join("sw")).unwrap();
    let half: String = sorted.iter().take(6).map(|l| format!("{l}\n")).collect();
    std::fs::write(&progress, format!("{first}\n{half}7,weigh")).unwrap();
    let err = resumed(&s, &out);
    assert!(err.is_empty(), "{err}");
    assert_eq!(text(&out.join("sw.csv")), format!("{header}\n{rows}"));
    let computed = kept_plans(&out.join("sw"));
    assert_eq!(computed.len(), 6, "{computed:?}");
    assert!(
        computed
            .iter()
            .all(|n| (6..12).any(|k| n.starts_with(&format!("case-{k}-")))),
        "saved cases taken, the others computed: {computed:?}"
    );
    assert!(!progress.exists());

    // A progress file of other content (another hash), or a run without --resume, starts over.
    for (hash_line, resume) in [("hash 0000", true), (first, false)] {
        std::fs::remove_file(out.join("sw.csv")).unwrap();
        std::fs::write(
            &progress,
            format!("{hash_line}\n{}", mark(&half, 3, "123.5")),
        )
        .unwrap();
        let mut args = vec![s.to_str().unwrap(), "--out", out.to_str().unwrap()];
        if resume {
            args.push("--resume");
        }
        let r = batch(&args);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        assert_eq!(text(&out.join("sw.csv")), expected, "{hash_line} {resume}");
    }
}

#[test]
fn resume_with_plots_draws_the_missing_pictures() {
    let t = tempfile::tempdir().unwrap();
    let s = t.path().join("scen");
    std::fs::create_dir_all(&s).unwrap();
    std::fs::write(s.join("p.toml"), "[plan]\nangle_deg = 30\n").unwrap();
    std::fs::write(s.join("sw.toml"), SWEEP).unwrap();
    std::fs::write(
        s.join("one.toml"),
        "[plan]\nangle_deg = 30\n[sweep]\nschemes = [\"weighted\", \"search\"]\n",
    )
    .unwrap();
    let out = t.path().join("out");
    let args = [
        s.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--plots",
    ];
    let r = batch(&args);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let pictures = [
        "p-fig5.png",
        "p-fig6.svg",
        "p.html",
        "sw_search.png",
        "sw_weighted.svg",
        "one-schemes.png",
        "one-error.png",
    ];
    let before: Vec<Vec<u8>> = pictures
        .iter()
        .map(|p| std::fs::read(out.join(p)).unwrap())
        .collect();
    // A kill while drawing: pictures missing, one cut short in its temporary file.
    for p in pictures {
        std::fs::remove_file(out.join(p)).unwrap();
    }
    let host = spherestep::io::output::host_tag();
    let torn = spherestep::io::output::temp_path_of(&out.join("p-error.png"), &host, dead_pid());
    std::fs::write(&torn, b"half a png").unwrap();
    let mut resume = args.to_vec();
    resume.push("--resume");
    let r = batch(&resume);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let said = String::from_utf8_lossy(&r.stdout);
    // The plan and the many-axis sweep are drawn from their files; the one-axis sweep's
    // picture needs its plans, so it alone is computed again.
    assert!(said.contains("1 computed, 2 up to date"), "{said}");
    for (p, b) in pictures.iter().zip(&before) {
        let now = std::fs::read(out.join(p)).unwrap();
        assert!(&now == b, "{p} drawn again, same bytes");
    }
    assert!(!torn.exists());
    // Nothing missing: nothing drawn or computed.
    let r = batch(&resume);
    let said = String::from_utf8_lossy(&r.stdout);
    assert!(said.contains("0 computed, 3 up to date"), "{said}");
}

/// Sets column `col` of `case` in sweep CSV rows to `value`.
fn set(rows: &str, case: usize, col: usize, value: &str) -> String {
    rows.lines()
        .map(|l| {
            let mut f: Vec<String> = l.split(',').map(str::to_string).collect();
            if f[0] == case.to_string() {
                f[col] = value.to_string();
            }
            f.join(",") + "\n"
        })
        .collect()
}

/// The sweep `SWEEP` written into `dir` and run twice: uninterrupted into `full`, and into
/// `out` by a run that saved every case in its progress file but could not write its result
/// (a folder stood where `sw.csv` goes; removed after). The scenario, `full` and `out`.
fn saved_sweep(dir: &Path) -> (PathBuf, PathBuf, PathBuf) {
    let s = dir.join("sw.toml");
    std::fs::write(&s, SWEEP).unwrap();
    let full = dir.join("full");
    let r = batch(&[s.to_str().unwrap(), "--out", full.to_str().unwrap()]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let out = dir.join("out");
    std::fs::create_dir_all(out.join("sw.csv").join("blocker")).unwrap();
    let r = batch(&[s.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(r.status.code(), Some(1));
    std::fs::remove_dir_all(out.join("sw.csv")).unwrap();
    (s, full, out)
}

/// Progress rows that are not what this sweep writes (a hand-edited
/// `reached`, a number that is not one, another case's settings, a case the sweep does not
/// have, a short row) are not copied into the result: those cases are computed again, with a
/// warning naming the progress file; the run succeeds.
#[test]
fn damaged_progress_rows_are_computed_again_with_a_warning() {
    let t = tempfile::tempdir().unwrap();
    let (s, full, out) = saved_sweep(t.path());
    let expected = text(&full.join("sw.csv"));
    let progress = out.join("sw.csv.progress");
    let saved = text(&progress);
    let (first, rows) = saved.split_once('\n').unwrap();
    let mut damaged = set(rows, 3, 12, "maybe"); // `reached`
    damaged = set(&damaged, 5, 8, "x");
    damaged = set(&damaged, 7, 1, "nonsense");
    damaged = set(&damaged, 9, 0, "99");
    damaged.push_str("1,2,3\n");
    std::fs::write(&progress, format!("{first}\n{damaged}")).unwrap();
    let err = resumed(&s, &out);
    assert_eq!(
        text(&out.join("sw.csv")),
        expected,
        "damaged rows not copied"
    );
    let warning = err
        .lines()
        .find(|l| {
            l.starts_with("spherestep: warning: ") && l.contains(&progress.display().to_string())
        })
        .unwrap_or_else(|| panic!("no warning naming the progress file: {err}"));
    assert!(warning.contains("5 damaged row(s)"), "{warning}");
    assert!(
        warning.contains("column `reached`: expected true or false, got \"maybe\""),
        "{warning}"
    );
    assert!(warning.contains("computed again"), "{warning}");
    assert!(!progress.exists());
}

/// A saved row with one number changed by hand still reads as a row of this sweep, but its
/// checksum no longer verifies: `--resume` computes the case again, with a warning naming the
/// progress file, and the result has the bytes of an uninterrupted run (the edited number
/// used to land in `sw.csv`, its `.hash` matching). A row whose checksum was removed is
/// computed again too.
#[test]
fn an_edited_progress_row_is_computed_again() {
    let t = tempfile::tempdir().unwrap();
    let (s, full, out) = saved_sweep(t.path());
    let expected = std::fs::read(full.join("sw.csv")).unwrap();
    let progress = out.join("sw.csv.progress");
    let saved = text(&progress);
    let (first, rows) = saved.split_once('\n').unwrap();
    let case3 = rows.lines().find(|l| l.starts_with("3,")).unwrap();
    assert!(!case3.contains(",0.125,"), "{case3}");
    // case 3's max_axis_error_deg edited, its checksum kept; case 5's checksum dropped
    let edited: String = mark(rows, 3, "0.125")
        .lines()
        .map(|l| match l.starts_with("5,") {
            true => format!("{}\n", row_of(l)),
            false => format!("{l}\n"),
        })
        .collect();
    std::fs::write(&progress, format!("{first}\n{edited}")).unwrap();
    let err = resumed(&s, &out);
    let got = std::fs::read(out.join("sw.csv")).unwrap();
    assert!(
        got == expected,
        "the bytes of an uninterrupted run:\n{}",
        String::from_utf8_lossy(&got)
    );
    assert_eq!(
        text(&out.join("sw.csv.hash")),
        text(&full.join("sw.csv.hash"))
    );
    let warning = err
        .lines()
        .find(|l| l.contains(&progress.display().to_string()))
        .unwrap_or_else(|| panic!("no warning naming the progress file: {err}"));
    assert!(warning.contains("2 damaged row(s)"), "{warning}");
    assert!(
        warning.contains("case 3: expected the row's checksum after it"),
        "{warning}"
    );
    assert!(warning.contains("case 5: expected the row's checksum after it, got none"));
    assert!(!progress.exists());
}

/// How a test damages a file's text.
type Damage = fn(&str) -> String;

/// A result file cut short, emptied or replaced with garbage is not kept as
/// up to date by `--resume` (its bytes are checked against the digest its `.hash` records): it
/// is computed again, with a warning naming it, and the run succeeds with the same files. A
/// result of an older spherestep (no digest recorded) is checked by its contents.
#[test]
fn damaged_results_are_computed_again_with_a_warning() {
    let t = tempfile::tempdir().unwrap();
    let s = t.path().join("scen");
    std::fs::create_dir_all(&s).unwrap();
    std::fs::write(s.join("p.toml"), "[plan]\nangle_deg = 30\n").unwrap();
    std::fs::write(s.join("sw.toml"), SWEEP).unwrap();
    let out = t.path().join("out");
    let args = [s.to_str().unwrap(), "--out", out.to_str().unwrap()];
    let r = batch(&args);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let names = [
        "p.csv",
        "sw.csv",
        "p.csv.hash",
        "sw.csv.hash",
        "summary.csv",
    ];
    let good: Vec<String> = names.iter().map(|n| text(&out.join(n))).collect();
    let mut resume = args.to_vec();
    resume.push("--resume");
    let damages: [(&str, Damage); 4] = [
        ("cut mid-line", |t| t[..t.len() / 2].to_string()),
        ("cut at a line end", |t| {
            let body = t.trim_end_matches('\n');
            body[..body.rfind('\n').unwrap() + 1].to_string()
        }),
        ("garbage", |_| "garbage\n\u{0}\u{1}".to_string()),
        ("emptied", |_| String::new()),
    ];
    for (what, damage) in damages {
        for (n, g) in names.iter().zip(&good).take(2) {
            std::fs::write(out.join(n), damage(g)).unwrap();
        }
        let r = batch(&resume);
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(r.status.success(), "{what}: {err}");
        let said = String::from_utf8_lossy(&r.stdout);
        assert!(
            said.starts_with("2 computed, 0 up to date"),
            "{what}: {said}"
        );
        for n in ["p.csv", "sw.csv"] {
            let file = out.join(n).display().to_string();
            assert!(
                err.lines().any(|l| l.starts_with("spherestep: warning: ")
                    && l.contains(&format!(
                        "{file}: its contents are not those recorded in {file}.hash"
                    ))
                    && l.contains("computed again")),
                "{what}: no warning naming {file}: {err}"
            );
        }
        for (n, g) in names.iter().zip(&good) {
            assert_eq!(&text(&out.join(n)), g, "{what}: {n}");
        }
    }
    // the older form of `.hash` (the scenario's hash alone): a whole result is kept, silently
    for n in ["p.csv.hash", "sw.csv.hash"] {
        let h = text(&out.join(n));
        std::fs::write(out.join(n), format!("{}\n", h.lines().next().unwrap())).unwrap();
    }
    let r = batch(&resume);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(
        String::from_utf8_lossy(&r.stdout).starts_with("0 computed, 2 up to date"),
        "{err}"
    );
    assert!(!err.contains("warning"), "{err}");
    // ... and a damaged one computed again
    let reached = if good[1].contains(",true,") {
        ",true,"
    } else {
        ",false,"
    };
    std::fs::write(out.join("sw.csv"), good[1].replacen(reached, ",maybe,", 1)).unwrap();
    let r = batch(&resume);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(
        String::from_utf8_lossy(&r.stdout).starts_with("1 computed, 1 up to date"),
        "{err}"
    );
    assert!(err.contains("sw.csv: its contents are not those"), "{err}");
    for (n, g) in names.iter().zip(&good).filter(|(n, _)| **n != "p.csv.hash") {
        assert_eq!(&text(&out.join(n)), g, "{n}");
    }
}
