//! How messages show numbers and text: [`shown`] (a number, in exponent form when extreme) and
//! [`printable`] (text with its control characters escaped). A leaf: every layer's errors use
//! it, and it uses nothing of the crate.

/// A number as a message shows it: as written for ordinary magnitudes, in exponent form
/// (`1e300`) for the very large or small, so that no message spells out 300 digits.
pub fn shown(x: f64) -> String {
    let a = x.abs();
    if a != 0.0 && a.is_finite() && !(1e-4..1e15).contains(&a) {
        format!("{x:e}")
    } else {
        x.to_string()
    }
}

/// Text as a message or report shows it: control characters (NUL, terminal escapes, bells,
/// line ends) escaped as Rust does (`\0`, `\u{1b}`, `\n`), everything else as it is, so that
/// what a file or a device holds never reaches the terminal raw.
pub fn printable(text: &str) -> String {
    escaped(text, &[])
}

/// [`printable`], keeping line ends and tabs (for whole messages that may span lines).
pub fn printable_lines(text: &str) -> String {
    escaped(text, &['\n', '\t'])
}

fn escaped(text: &str, kept: &[char]) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        if c.is_control() && !kept.contains(&c) {
            out.extend(c.escape_debug());
        } else {
            out.push(c);
        }
    }
    out
}

#[cfg(test)]
mod shown_tests {
    #[test]
    fn printable_escapes_control_characters_only() {
        assert_eq!(
            super::printable("a\0b\u{1b}[31m'\"\\é\n"),
            "a\\0b\\u{1b}[31m'\"\\é\\n"
        );
        assert_eq!(
            super::printable_lines("x\u{7}\ny\tz\\t"),
            "x\\u{7}\ny\tz\\t"
        );
    }

    #[test]
    fn shown_keeps_ordinary_numbers_and_shortens_extreme_ones() {
        assert_eq!(super::shown(60001.0), "60001");
        assert_eq!(super::shown(0.25), "0.25");
        assert_eq!(super::shown(1e300), "1e300");
        assert_eq!(super::shown(-2e19), "-2e19");
        assert_eq!(super::shown(1e-300), "1e-300");
        assert_eq!(super::shown(f64::INFINITY), "inf");
        assert_eq!(super::shown(0.0), "0");
    }
}
