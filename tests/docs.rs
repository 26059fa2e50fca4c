//! The docs cannot drift from the code: every ```` ```toml ```` block in the README and in the
//! book (`docs/src/**/*.md`) parses as a job ([`JobSpec::from_toml`], then
//! [`JobSpec::validate`], and its `[diagnose]` section by [`DiagnoseSpec::from_job_text`], none of
//! which reads the model or the data), or, when it has no
//! `[model]`, as a job fragment merged into a minimal job. The job types deny unknown fields, so
//! a misspelled or removed key in a snippet fails here. A block that is not a job is fenced
//! otherwise (` ```text `, ` ```yaml `). A block may be `{{#include FILE}}` of a real job file.
//!
//! And an offline link check: every relative link and image in README.md, ARCHITECTURE.md,
//! CHANGELOG.md and the book resolves to a file or folder of the repository, an `#anchor` into a
//! markdown file to one of its headings (mdBook's and GitHub's slugs: lowercase, whitespace to
//! `-`, punctuation other than `-` and `_` dropped, repeats numbered `-1`, `-2`, ...), and every
//! `{{#include FILE}}` to a file. External links are not fetched.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use fmucal_diagnose::spec::DiagnoseSpec;
use fmucal_shared::job::JobSpec;

/// The repository root (this crate is `shared/`).
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).to_path_buf()
}

/// README.md, ARCHITECTURE.md, CHANGELOG.md and every markdown file under docs/src.
fn markdown_files() -> Vec<PathBuf> {
    let root = root();
    let mut files: Vec<PathBuf> =
        ["README.md", "ARCHITECTURE.md", "CHANGELOG.md"].iter().map(|f| root.join(f)).collect();
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
            .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
            .map(|e| e.expect("a directory entry").path())
            .collect();
        entries.sort();
        for path in entries {
            if path.is_dir() {
                walk(&path, out);
            } else if path.extension().is_some_and(|x| x == "md") {
                out.push(path);
            }
        }
    }
    walk(&root.join("docs/src"), &mut files);
    for f in &files {
        assert!(f.is_file(), "{} is missing", f.display());
    }
    files
}

/// A fenced code block: its info string's first word, first line number and content (the
/// opening fence's indentation removed).
struct Block {
    lang: String,
    line: usize,
    text: String,
}

/// The fenced code blocks of a markdown text, and the lines outside them (with their numbers).
fn split_fences(text: &str) -> (Vec<Block>, Vec<(usize, String)>) {
    let mut blocks = Vec::new();
    let mut prose = Vec::new();
    let mut open: Option<(String, usize, Block)> = None;
    for (i, line) in text.lines().enumerate() {
        let number = i + 1;
        let trimmed = line.trim_start();
        let indent = line.len() - trimmed.len();
        let fence: String = trimmed.chars().take_while(|&c| c == '`' || c == '~').collect();
        let is_fence = fence.len() >= 3 && fence.chars().all(|c| c == fence.chars().next().unwrap());
        match open.take() {
            None if is_fence => {
                let lang = trimmed[fence.len()..].split(|c: char| c.is_whitespace() || c == ',').next().unwrap_or("");
                let block = Block { lang: lang.to_string(), line: number, text: String::new() };
                open = Some((fence, indent, block));
            }
            None => prose.push((number, line.to_string())),
            Some((f, _, block)) if is_fence && fence.starts_with(&f) && trimmed[fence.len()..].trim().is_empty() => {
                blocks.push(block);
            }
            Some((f, ind, mut block)) => {
                let cut = line.len() - line.trim_start().len();
                block.text.push_str(&line[cut.min(ind)..]);
                block.text.push('\n');
                open = Some((f, ind, block));
            }
        }
    }
    if let Some((_, _, block)) = open {
        panic!("a code block opened at line {} is never closed", block.line);
    }
    (blocks, prose)
}

/// The `{{#include PATH}}` directives of a text: (line number within the text, path as written).
fn includes(text: &str) -> Vec<(usize, String)> {
    let mut found = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let mut rest = line;
        while let Some(at) = rest.find("{{#include") {
            let after = &rest[at + "{{#include".len()..];
            let end = after.find("}}").unwrap_or(after.len());
            found.push((i, after[..end].trim().to_string()));
            rest = &after[end..];
        }
    }
    found
}

/// An include's file, without mdBook's `:LINES` or `:ANCHOR` suffix, against `dir`.
fn include_path(dir: &Path, written: &str) -> PathBuf {
    dir.join(written.split(':').next().unwrap_or(written))
}

/// The text of an include, with mdBook's line range (`:FROM:TO`, 1-based, either side may be
/// empty) applied.
fn include_text(dir: &Path, written: &str) -> Result<String, String> {
    let path = include_path(dir, written);
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{{{{#include {written}}}}}: {e}"))?;
    let mut parts = written.split(':').skip(1);
    let (Some(from), to) = (parts.next(), parts.next()) else { return Ok(text) };
    let number =
        |s: &str| s.parse::<usize>().map_err(|_| format!("{{{{#include {written}}}}}: only line ranges are supported"));
    let lines: Vec<&str> = text.lines().collect();
    let from = if from.is_empty() { 1 } else { number(from)? };
    let to = match to {
        None => from,
        Some("") => lines.len(),
        Some(t) => number(t)?,
    };
    Ok(lines.get(from.saturating_sub(1)..to.min(lines.len())).unwrap_or_default().join("\n"))
}

/// A minimal valid job that a fragment is merged into.
const MINIMAL_JOB: &str = r#"
[model]
path = "model.fmu"

[data]
path = "data.csv"

[[outputs]]
variable = "y"
column = "y"

[[parameters]]
name = "p"
start = 1.0
lower = 0.0
upper = 2.0
"#;

/// Parses a snippet as a job, or as a fragment of one (no `[model]`): its tables replace the
/// minimal job's, its arrays of tables are appended to the minimal job's. Then validates it.
fn check_job_snippet(text: &str) -> Result<(), String> {
    let table: toml::Table = toml::from_str(text).map_err(|e| format!("not TOML: {e}"))?;
    let job_text = if table.contains_key("model") {
        text.to_string()
    } else {
        let mut job: toml::Table = toml::from_str(MINIMAL_JOB).expect("the minimal job is TOML");
        for (key, value) in table {
            match (job.get_mut(&key), value) {
                (Some(toml::Value::Array(have)), toml::Value::Array(more)) => have.extend(more),
                (_, value) => {
                    job.insert(key, value);
                }
            }
        }
        toml::to_string(&job).map_err(|e| format!("cannot write the merged job: {e}"))?
    };
    let spec = JobSpec::from_toml(&job_text, Path::new(".")).map_err(|e| e.to_string())?;
    spec.validate().map_err(|e| e.to_string())?;
    // The [diagnose] section is the diagnosis's to read.
    DiagnoseSpec::from_job_text(&job_text).map(|_| ()).map_err(|e| e.to_string())
}

/// Every problem with the `toml` blocks of one markdown text (`dir`: its folder, for includes).
fn snippet_problems(name: &str, dir: &Path, markdown: &str) -> Vec<String> {
    let (blocks, _) = split_fences(markdown);
    let mut problems = Vec::new();
    for block in blocks.iter().filter(|b| b.lang == "toml") {
        let mut text = String::new();
        for line in block.text.lines() {
            match includes(line).first() {
                Some((_, written)) => match include_text(dir, written) {
                    Ok(t) => text.push_str(&t),
                    Err(e) => problems.push(format!("{name}:{}: {e}", block.line)),
                },
                None => text.push_str(line),
            }
            text.push('\n');
        }
        if let Err(e) = check_job_snippet(&text) {
            problems.push(format!("{name}:{}: the toml block is not a valid job or job fragment: {e}", block.line));
        }
    }
    problems
}

/// A heading's anchor as mdBook and GitHub make it.
fn slug(heading: &str) -> String {
    // Links in a heading count by their text.
    let mut text = String::new();
    let mut rest = heading;
    while let Some(open) = rest.find('[') {
        let Some(mid) = rest[open..].find("](") else { break };
        let Some(close) = rest[open + mid..].find(')') else { break };
        text.push_str(&rest[..open]);
        text.push_str(&rest[open + 1..open + mid]);
        rest = &rest[open + mid + close + 1..];
    }
    text.push_str(rest);
    text.trim()
        .chars()
        .filter_map(|c| {
            if c.is_alphanumeric() || c == '_' || c == '-' {
                Some(c.to_lowercase().collect::<String>())
            } else if c.is_whitespace() {
                Some("-".to_string())
            } else {
                None
            }
        })
        .collect()
}

/// The anchors of a markdown text's headings, repeats numbered as mdBook and GitHub do.
fn anchors(markdown: &str) -> HashSet<String> {
    let (_, prose) = split_fences(markdown);
    let mut seen = HashSet::new();
    for (_, line) in prose {
        let Some(rest) = line.strip_prefix('#') else { continue };
        let text = rest.trim_start_matches('#');
        if !text.starts_with(' ') {
            continue;
        }
        let base = slug(text.trim().trim_end_matches('#'));
        let mut id = base.clone();
        let mut n = 1;
        while !seen.insert(id.clone()) {
            id = format!("{base}-{n}");
            n += 1;
        }
    }
    seen
}

/// A line without its inline code spans.
fn without_code_spans(line: &str) -> String {
    let mut out = String::new();
    let mut inside = false;
    for c in line.chars() {
        if c == '`' {
            inside = !inside;
        } else if !inside {
            out.push(c);
        }
    }
    out
}

/// The link targets of a markdown text outside code: inline links and images `](TARGET)` and
/// reference definitions `[label]: TARGET`, with their line numbers.
fn links(markdown: &str) -> Vec<(usize, String)> {
    let (_, prose) = split_fences(markdown);
    let mut found = Vec::new();
    for (number, line) in prose {
        let line = without_code_spans(&line);
        let mut rest = line.as_str();
        while let Some(at) = rest.find("](") {
            let after = &rest[at + 2..];
            let end = after.find(')').unwrap_or(after.len());
            let target = after[..end].split_whitespace().next().unwrap_or("").trim_matches(['<', '>']);
            found.push((number, target.to_string()));
            rest = &after[end..];
        }
        let trimmed = line.trim_start();
        if trimmed.starts_with('[')
            && let Some(close) = trimmed.find("]:")
        {
            let target = trimmed[close + 2..].split_whitespace().next().unwrap_or("");
            found.push((number, target.to_string()));
        }
    }
    found
}

/// Every broken relative link, anchor and include of one markdown file.
fn link_problems(file: &Path, markdown: &str) -> Vec<String> {
    let root = root();
    let name = file.strip_prefix(&root).unwrap_or(file).display().to_string();
    let dir = file.parent().expect("a file has a folder");
    let mut problems = Vec::new();
    for (number, target) in links(markdown) {
        if target.is_empty() {
            problems.push(format!("{name}:{number}: an empty link"));
            continue;
        }
        if target.contains("://") || target.starts_with("mailto:") {
            continue;
        }
        let (path, anchor) = match target.split_once('#') {
            Some((p, a)) => (p, Some(a)),
            None => (target.as_str(), None),
        };
        let resolved = if path.is_empty() { file.to_path_buf() } else { dir.join(path) };
        if !resolved.exists() {
            problems.push(format!("{name}:{number}: {target}: {} does not exist", resolved.display()));
            continue;
        }
        if let Some(anchor) = anchor
            && resolved.extension().is_some_and(|x| x == "md")
        {
            // An anchor into this file is looked up in the text being checked.
            let text = if path.is_empty() {
                markdown.to_string()
            } else {
                std::fs::read_to_string(&resolved).unwrap_or_default()
            };
            if !anchors(&text).contains(anchor) {
                problems.push(format!("{name}:{number}: {target}: no heading with the anchor #{anchor}"));
            }
        }
    }
    for (i, written) in includes(markdown) {
        if !include_path(dir, &written).is_file() {
            problems.push(format!("{name}:{}: {{{{#include {written}}}}}: no such file", i + 1));
        }
    }
    problems
}

#[test]
fn every_toml_block_in_the_readme_and_the_book_is_a_valid_job_or_job_fragment() {
    let mut problems = Vec::new();
    let mut checked = 0;
    for file in markdown_files() {
        let text = std::fs::read_to_string(&file).expect("a readable markdown file");
        checked += split_fences(&text).0.iter().filter(|b| b.lang == "toml").count();
        let name = file.strip_prefix(root()).unwrap_or(&file).display().to_string();
        problems.extend(snippet_problems(&name, file.parent().unwrap(), &text));
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    assert!(checked >= 5, "only {checked} toml blocks found: is the book where this test looks?");
}

#[test]
fn every_relative_link_anchor_and_include_in_the_docs_resolves() {
    let mut problems = Vec::new();
    for file in markdown_files() {
        let text = std::fs::read_to_string(&file).expect("a readable markdown file");
        problems.extend(link_problems(&file, &text));
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn a_snippet_with_an_unknown_or_misspelled_key_fails() {
    let dir = root();
    let bad = [
        "```toml\n[optimizer]\nalgorithm = \"nelder-mead\"\nxtol = 1e-3\n```\n",
        "```toml\n[[parameters]]\nname = \"k\"\nstart = 1.0\nlower = 0.0\nupper = 2.0\nstep = 0.1\n```\n",
        "```toml\n[model]\npath = \"m.fmu\"\n\n[data]\npath = \"d.csv\"\n\n[[outputs]]\nvariable = \"x\"\ncolumn = \"x\"\n\n[[parameters]]\nname = \"k\"\nstart = 1.0\nlower = 0.0\nupper = 2.0\n\n[solver]\nname = \"bdf\"\n```\n",
        "   ```toml\n   [[effects]]\n   kind = \"coulomb_friction\"\n   state = \"mass.v\"\n   parameters = { strength = { start = 0.0, lower = 0.0, upper = 1.0 } }\n   ```\n",
        "```toml\n[diagnose]\ntopk = 8\n```\n",
    ];
    for markdown in bad {
        assert_eq!(snippet_problems("bad.md", &dir, markdown).len(), 1, "not refused:\n{markdown}");
    }
    let good = "```toml\n[optimizer]\nalgorithm = \"nelder-mead\"\nx_tol = 1e-3\n```\n```text\nnot = [a job\n```\n";
    assert_eq!(snippet_problems("good.md", &dir, good), Vec::<String>::new());
}

#[test]
fn a_broken_link_or_anchor_fails_and_code_is_not_read_as_links() {
    let file = root().join("docs/src/introduction.md");
    let markdown = "# Title\n\n## A `code` heading (here)\n\n[ok](#a-code-heading-here) [ok](../../README.md#try-it)\n\
                    [gone](missing.md) [no anchor](../../README.md#nowhere) [self](#nowhere)\n\
                    `[not a link](missing.md)`\n\n```text\n[not a link](missing.md)\n```\n{{#include missing.toml}}\n";
    let problems = link_problems(&file, markdown);
    assert_eq!(problems.len(), 4, "{problems:#?}");
    assert_eq!(slug("Discrepancy discovery (`fmucal diagnose`)"), "discrepancy-discovery-fmucal-diagnose");
    assert_eq!(slug("The `[diagnose]` section"), "the-diagnose-section");
    assert_eq!(slug("Nelder–Mead and DE against SciPy"), "neldermead-and-de-against-scipy");
}
