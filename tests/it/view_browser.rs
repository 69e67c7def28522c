//! Opens the page written by `spherestep view` in a real headless browser (Debian's `chromium`)
//! and reads back the result of the page's own `#selftest`: no script error, a non-blank
//! canvas, and stepping changes the displayed step number and the orientation. When chromium is
//! not installed the test prints "skipped: chromium not installed" and passes
//! (`.ci/install-chromium` installs it in CI). `SPHERESTEP_CHROMIUM` may name another binary.

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn chromium() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("SPHERESTEP_CHROMIUM") {
        let p = PathBuf::from(p);
        return p.exists().then_some(p);
    }
    ["/usr/bin/chromium", "/usr/bin/chromium-browser"]
        .iter()
        .map(PathBuf::from)
        .find(|p| p.exists())
}

/// Runs chromium headless on `url` with the extra arguments; kills it after `limit`.
fn run_chromium(exe: &Path, extra: &[&str], url: &str, limit: Duration) -> Output {
    let profile = tempfile::tempdir().unwrap();
    let mut child = Command::new(exe)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--disable-extensions",
            "--window-size=1200,800",
        ])
        .arg(format!("--user-data-dir={}", profile.path().display()))
        .args(extra)
        .arg(url)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("chromium starts");
    // Read the pipes on threads so a full pipe cannot block the browser.
    let mut so = child.stdout.take().unwrap();
    let mut se = child.stderr.take().unwrap();
    let t_out = std::thread::spawn(move || {
        let mut b = Vec::new();
        std::io::Read::read_to_end(&mut so, &mut b).ok();
        b
    });
    let t_err = std::thread::spawn(move || {
        let mut b = Vec::new();
        std::io::Read::read_to_end(&mut se, &mut b).ok();
        b
    });
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > limit {
            child.kill().ok();
            let s = child.wait().unwrap();
            panic!(
                "chromium did not finish within {limit:?} ({s}); stderr:\n{}",
                String::from_utf8_lossy(&t_err.join().unwrap())
            );
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    Output {
        status,
        stdout: t_out.join().unwrap(),
        stderr: t_err.join().unwrap(),
    }
}

fn html_unescape(s: &str) -> String {
    s.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&#39;", "'")
        .replace("&amp;", "&")
}

/// The JSON the page's self-test wrote into `<pre id="selftest-result">`.
fn selftest_result(dom: &str) -> Option<Value> {
    let start = dom.find("id=\"selftest-result\"")?;
    let open_end = start + dom[start..].find('>')? + 1;
    let close = open_end + dom[open_end..].find("</pre>")?;
    serde_json::from_str(&html_unescape(&dom[open_end..close])).ok()
}

fn quat(v: &Value) -> Vec<f64> {
    serde_json::from_value(v.clone()).unwrap_or_else(|_| panic!("a quaternion, got {v}"))
}

fn close(a: &[f64], b: &[f64]) -> bool {
    a.len() == 4 && b.len() == 4 && a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-9)
}

#[test]
fn page_runs_in_headless_chromium() {
    let Some(exe) = chromium() else {
        // Written to the stderr handle directly so that it shows without --nocapture.
        use std::io::Write;
        let _ = writeln!(
            std::io::stderr(),
            "page_runs_in_headless_chromium: skipped: chromium not installed \
             (apt-get install chromium, or CI=true .ci/install-chromium)"
        );
        return;
    };
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("plan.html");
    let o = Command::new(env!("CARGO_BIN_EXE_spherestep"))
        .arg("view")
        .arg(data.join("view_plan_z.csv"))
        .arg("--out")
        .arg(&page)
        .arg("--sim")
        .arg(data.join("view_sim_z.csv"))
        .arg("--axis")
        .arg("0,0,1")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let plan = spherestep::io::planfile::read_plan(&data.join("view_plan_z.csv")).unwrap();
    let plan_q: Vec<Vec<f64>> = plan
        .iter()
        .map(|r| spherestep::model::geometry::xyzw(&r.q).to_vec())
        .collect();

    let url = format!("file://{}#selftest", page.display());
    let out = run_chromium(&exe, &["--dump-dom"], &url, Duration::from_secs(120));
    let dom = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    let r = selftest_result(&dom).unwrap_or_else(|| {
        panic!(
            "no self-test result in the dumped DOM ({}); stderr:\n{stderr}\nDOM (start):\n{}",
            out.status,
            &dom[..dom.len().min(2000)]
        )
    });
    println!("selftest result: {r}");

    // no script error
    assert_eq!(r["errors"], serde_json::json!([]), "script errors: {r}");
    // a non-blank canvas: at least 2% of the pixels differ from the background
    let total = r["totalPixels"].as_f64().unwrap();
    let drawn = r["nonBlankPixels"].as_f64().unwrap();
    assert!(total > 10_000.0, "canvas too small: {r}");
    assert!(
        drawn > 0.02 * total,
        "canvas looks blank: {drawn} of {total} pixels drawn"
    );
    assert!(r["nonBlankAfterNext"].as_f64().unwrap() > 0.02 * total);
    assert_eq!(r["stepCount"], 4);
    // stepping changes the displayed step and the orientation
    assert_eq!(r["stepBefore"], 0);
    assert_eq!(r["labelBefore"], "0");
    assert!(close(&quat(&r["orientationBefore"]), &plan_q[0]), "{r}");
    assert_eq!(r["stepAfterNext"], 1);
    assert_eq!(r["labelAfterNext"], "1");
    let after = quat(&r["orientationAfterNext"]);
    assert!(
        !close(&after, &quat(&r["orientationBefore"])),
        "orientation did not change: {r}"
    );
    assert!(
        close(&after, &plan_q[1]),
        "orientation after next: {after:?} vs {:?}",
        plan_q[1]
    );
    assert!(
        close(&quat(&r["displayedAfterNext"]), &plan_q[1]),
        "drawn orientation: {r}"
    );
    assert_eq!(r["stepAfterSetLast"], 3);
    assert_eq!(r["labelAfterSetLast"], "3");
    assert_eq!(r["stepAfterPrev"], 2);
    assert_eq!(r["labelAfterPrev"], "2");
    assert!(close(&quat(&r["orientationAfterPrev"]), &plan_q[2]), "{r}");

    // the page still draws without the self-test (plain load, screenshot)
    let shot = dir.path().join("shot.png");
    let out = run_chromium(
        &exe,
        &[&format!("--screenshot={}", shot.display())],
        &format!("file://{}#step=2", page.display()),
        Duration::from_secs(120),
    );
    assert!(
        shot.exists() && std::fs::metadata(&shot).unwrap().len() > 10_000,
        "no screenshot ({}): {}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
}
