//! `fmucal inspect` through the real binary: local variables are counted, and listed with
//! `--all`; long names, start values and descriptions are cut to their column with "…", so
//! every row keeps the header's columns.

mod common;

use std::path::Path;

fn inspect(args: &[&str], dir: &Path) -> String {
    let out = common::fmucal_in(dir).arg("inspect").args(args).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).unwrap()
}

/// The lines of the table under the title line starting with `title`: its header, then its rows.
fn table<'a>(text: &'a str, title: &str) -> Vec<&'a str> {
    text.lines().skip_while(|l| !l.starts_with(title)).skip(1).take_while(|l| !l.is_empty()).collect()
}

#[test]
fn local_variables_are_counted_and_listed_with_all() {
    let dir = tempfile::tempdir().unwrap();
    // Decay's locals: der(x), and xAlias (an alias of x).
    let text = inspect(&["example:decay"], dir.path());
    assert!(!text.contains("\nLocals"), "{text}");
    assert!(text.contains("\n2 local variables not listed (valid as outputs too): --all lists them\n"), "{text}");

    let text = inspect(&["--all", "example:decay"], dir.path());
    assert!(!text.contains("not listed"), "{text}");
    let locals = table(&text, "Locals (2)");
    assert_eq!(locals.len(), 3, "{text}");
    assert!(locals[0].split_whitespace().eq(["name", "type", "start", "unit", "description"]), "{}", locals[0]);
    let names: Vec<&str> = locals[1..].iter().filter_map(|l| l.split_whitespace().next()).collect();
    assert_eq!(names, ["der(x)", "xAlias"]);
    assert!(locals[2].ends_with("alias of x"), "{}", locals[2]);
}

#[test]
fn long_names_start_values_and_descriptions_are_cut_to_their_column() {
    let dir = tempfile::tempdir().unwrap();
    let long_name = "plant.subsystem.actuator.crashTimeOfTheSecondaryUnit";
    let fmu = common::with_xml("decay", dir.path(), "Long.fmu", |xml| {
        xml.replace(r#"name="crashTime""#, &format!(r#"name="{long_name}""#))
            .replace(
                r#"<Real declaredType="Time" start="1e9"/>"#,
                r#"<Real declaredType="Time" start="0.12345678901234567"/>"#,
            )
            .replace(r#"description="decay rate""#, &format!(r#"description="decay rate, {}""#, "and more ".repeat(20)))
    });
    let text = inspect(&[fmu.to_str().unwrap()], dir.path());
    let parameters = table(&text, "Parameters (");
    let header = parameters[0];
    // Column starts, in characters ("…" is one character and several bytes).
    let at = |column: &str| header[..header.find(column).unwrap()].chars().count();
    let starts = [at("type"), at("start"), at("unit"), at("description")];
    for row in &parameters[1..] {
        let chars: Vec<char> = row.chars().collect();
        for s in starts.into_iter().filter(|s| *s < chars.len()) {
            assert!(chars[s - 1] == ' ' && chars[s] != ' ', "a cell overflows its column:\n{header}\n{row}");
        }
    }
    let cells = |name: &str| -> Vec<String> {
        let row = parameters[1..].iter().find(|r| r.trim_start().starts_with(name)).unwrap();
        let chars: Vec<char> = row.chars().collect();
        let bounds = [2, starts[0], starts[1], starts[2], starts[3], chars.len()];
        bounds
            .windows(2)
            .map(|w| {
                chars[w[0].min(chars.len())..w[1].min(chars.len())].iter().collect::<String>().trim_end().to_owned()
            })
            .collect()
    };
    let crash = cells("plant.");
    assert!(crash[0].ends_with('…') && long_name.starts_with(crash[0].trim_end_matches('…')), "{crash:?}");
    assert_eq!(crash[0].chars().count(), 40, "{crash:?}");
    let kick = cells("kickTime");
    assert_eq!(kick[2], "0.1234567890123…", "{kick:?}");
    assert_eq!(kick[3], "s", "the unit of its declared type");
    let k = cells("k ");
    assert!(k[4].starts_with("decay rate, and more") && k[4].ends_with('…') && k[4].chars().count() == 80, "{k:?}");
    // --json has every value whole.
    let json = inspect(&["--json", fmu.to_str().unwrap()], dir.path());
    assert!(json.contains(long_name) && json.contains("0.1234567890123456"), "{json:.200}");
}
