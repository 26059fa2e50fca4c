//! Quoting text a user typed (a name in a job file, a value in a request) inside an error
//! message: bounded, so a 10 MB name gives a short line, and escaped, so control characters
//! (NUL, escape sequences, line breaks) and the invisible characters that reorder or hide text
//! on a terminal (bidirectional overrides such as U+202E, zero-width characters, a byte-order
//! mark) are shown as `\u{…}` instead of acting on the reader's screen.
//!
//! Every error that repeats user text uses [`quote_user_text`]; [`escape_user_text`] is the
//! same without the quotes, for a line as a whole (the CLI's last line of defence, and a
//! server's status message).

/// Characters of user text an error quotes before it cuts the rest: enough for any real name.
pub const MAX_QUOTED_CHARS: usize = 200;

/// Characters of a whole error line [`escape_user_text`] keeps when given this bound.
pub const MAX_ERROR_LINE_CHARS: usize = 4_000;

/// `text` in double quotes, escaped as [`escape_user_text`] does and cut after
/// [`MAX_QUOTED_CHARS`] characters, with its full size in bytes then said:
/// `"abc…" (10485760 bytes)`.
///
/// ```
/// use fmucal_fmi::quote::quote_user_text;
/// assert_eq!(quote_user_text("arm\u{202e}Joint\0"), r#""arm\u{202e}Joint\0""#);
/// assert!(quote_user_text(&"x".repeat(10_000_000)).ends_with("…\" (10000000 bytes)"));
/// ```
pub fn quote_user_text(text: &str) -> String {
    let mut out = String::with_capacity(text.len().min(MAX_QUOTED_CHARS * 2) + 2);
    out.push('"');
    let cut = push_escaped(&mut out, text, MAX_QUOTED_CHARS, true);
    if cut {
        out.push_str(&format!("…\" ({} bytes)", text.len()));
    } else {
        out.push('"');
    }
    out
}

/// `text` with every control, bidirectional-formatting and invisible character escaped
/// (`\0`, `\n`, `\u{202e}`; a backslash stays as it is) and cut after `max_chars` characters,
/// ending then with `… (N bytes in all)`.
pub fn escape_user_text(text: &str, max_chars: usize) -> String {
    let mut out = String::with_capacity(text.len().min(max_chars * 2));
    if push_escaped(&mut out, text, max_chars, false) {
        out.push_str(&format!("… ({} bytes in all)", text.len()));
    }
    out
}

/// Appends `text` escaped to `out`, up to `max_chars` characters of it; true if it was cut.
fn push_escaped(out: &mut String, text: &str, max_chars: usize, in_quotes: bool) -> bool {
    for (n, c) in text.chars().enumerate() {
        if n == max_chars {
            return true;
        }
        match c {
            '\0' => out.push_str("\\0"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            '"' if in_quotes => out.push_str("\\\""),
            '\\' if in_quotes => out.push_str("\\\\"),
            c if hidden(c) => out.push_str(&format!("\\u{{{:x}}}", c as u32)),
            c => out.push(c),
        }
    }
    false
}

/// Characters that act on a terminal or hide text rather than show as themselves: C0 and C1
/// controls, DEL, the bidirectional marks, embeddings, overrides and isolates, zero-width
/// characters, line and paragraph separators, and the byte-order mark.
fn hidden(c: char) -> bool {
    c.is_control()
        || matches!(
            c,
            '\u{061c}'
                | '\u{200b}'..='\u{200f}'
                | '\u{2028}'..='\u{202e}'
                | '\u{2060}'..='\u{2069}'
                | '\u{feff}'
                | '\u{fff9}'..='\u{fffb}'
        )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn controls_and_bidi_overrides_are_escaped_and_plain_text_is_kept() {
        assert_eq!(quote_user_text("armJoint.phi"), "\"armJoint.phi\"");
        assert_eq!(quote_user_text("Temperatur °C ü"), "\"Temperatur °C ü\"");
        assert_eq!(quote_user_text("a\0b\u{202e}c\u{1b}[2J\n"), r#""a\0b\u{202e}c\u{1b}[2J\n""#);
        assert_eq!(quote_user_text("say \"hi\" \\"), r#""say \"hi\" \\""#);
        assert_eq!(escape_user_text("x\u{2066}y\u{feff}\u{85}", 100), r"x\u{2066}y\u{feff}\u{85}");
    }

    #[test]
    fn long_text_is_cut_with_its_size_said() {
        let long = "é".repeat(5_000_000);
        let q = quote_user_text(&long);
        assert!(q.chars().count() < MAX_QUOTED_CHARS + 40, "{}", q.len());
        assert!(q.starts_with("\"éé") && q.ends_with("…\" (10000000 bytes)"), "{q}");
        let exact = "a".repeat(MAX_QUOTED_CHARS);
        assert_eq!(quote_user_text(&exact), format!("\"{exact}\""));
        let line = escape_user_text(&"a".repeat(10_000), 100);
        assert_eq!(line, format!("{}… (10000 bytes in all)", "a".repeat(100)));
    }
}
