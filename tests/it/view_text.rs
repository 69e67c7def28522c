//! The 3-D page's text: numbers never print as "-0.000", a plan that
//! predicts no settle time says so instead of "0.0000 s", and the legend sits over the view,
//! in sight at any window size. The page's pure text helpers run in node where it is
//! installed (else the test says "skipped: node not installed").

use std::process::Command;

fn asset(name: &str) -> String {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("assets/view")
        .join(name);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// The page script's pure text helpers (between its markers).
fn helpers() -> String {
    let js = asset("view.js");
    let start = js.find("// ---- pure text helpers").expect("start marker");
    let end = js
        .find("// ---- end of pure text helpers ----")
        .expect("end marker");
    js[start..end].to_string()
}

#[test]
fn numbers_and_settle_times_read_right() {
    let checks = r#"
const assert = require("assert");
assert.strictEqual(fmt(-0.0001, 3), "0.000");
assert.strictEqual(fmt(-0, 3), "0.000");
assert.strictEqual(fmt(-0.00004, 4), "0.0000");
assert.strictEqual(fmt(-0.2, 3), "-0.200");
assert.strictEqual(fmt(1.23456, 2), "1.23");
assert.strictEqual(fmt(NaN, 3), "\u2014");
assert.strictEqual(settleText(0), "not predicted");
assert.strictEqual(settleText(0.4126), "0.413 s");
assert.strictEqual(settleText(undefined), "not predicted");
console.log("ok");
"#;
    let code = format!("{}\n{checks}", helpers());
    let out = match Command::new("node").arg("-e").arg(&code).output() {
        Ok(o) => o,
        Err(_) => {
            eprintln!("skipped: node not installed");
            return;
        }
    };
    assert!(
        out.status.success() && String::from_utf8_lossy(&out.stdout).trim() == "ok",
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn the_legend_is_over_the_view() {
    let html = asset("view.html");
    let stage = html.find("<main id=\"stage\">").expect("stage");
    let stage_end = html.find("</main>").expect("end of stage");
    let legend = html.find("<div id=\"legend\">").expect("legend");
    assert!(
        stage < legend && legend < stage_end,
        "legend inside the view's stage"
    );
    let css = asset("view.css");
    let rule = css
        .split("\n#legend {")
        .nth(1)
        .and_then(|r| r.split('}').next())
        .expect("#legend rule");
    assert!(
        rule.contains("position: absolute") && rule.contains("top:"),
        "{rule}"
    );
    // And the page still uses the settle-time helper rather than printing 0.0000 s.
    let js = asset("view.js");
    assert!(js.contains("row(\"settle time\", settleText(st.settle_time_s))"));
}
