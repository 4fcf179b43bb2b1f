//! The documentation's links resolve: README.md and the mdBook under docs/.
//!
//! What is checked (every failure names the page, the line and the target):
//! - every Markdown link `[text](target)`, image `![alt](target)` and reference definition
//!   `[label]: target` in README.md and in every `docs/**/*.md` page that is not external
//!   (`http://`, `https://`, `mailto:`) points at a file or folder that exists, relative to the page;
//!   absolute paths and empty targets are errors (the book must build from any checkout);
//! - a `#anchor` on a link into a Markdown page (or on a link within the same page) names a heading
//!   of that page, by the slug rules GitHub and mdBook share: lowercase, whitespace to `-`, every
//!   other character but letters, digits, `-` and `_` dropped, repeated headings suffixed `-1`, `-2`;
//! - every page listed in docs/SUMMARY.md exists, and every `.md` file under docs/ but SUMMARY.md
//!   is listed there (mdBook builds only what SUMMARY.md lists);
//! - docs/book.toml keeps the book's source in docs/ itself (`src = "."`);
//! - README.md stays a front door: under 300 lines.
//!
//! Links inside fenced code blocks and inline code spans are not links and are not checked, so a
//! path quoted in backticks (`src/sim.rs`) may name a file that moves without breaking this test.
//! Plain Rust, std only.

use std::collections::{BTreeSet, HashMap};
use std::fs;
use std::path::{Component, Path, PathBuf};

/// The repository root (the package's manifest folder).
fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// README.md and every Markdown file under docs/, sorted, as paths relative to the root.
fn pages() -> Vec<PathBuf> {
    let mut out = vec![PathBuf::from("README.md")];
    let mut stack = vec![PathBuf::from("docs")];
    while let Some(dir) = stack.pop() {
        let entries = fs::read_dir(root().join(&dir))
            .unwrap_or_else(|e| panic!("cannot read {}: {e}", dir.display()));
        for entry in entries {
            let entry = entry.expect("a directory entry");
            let rel = dir.join(entry.file_name());
            let kind = entry.file_type().expect("a file type");
            if kind.is_dir() {
                stack.push(rel);
            } else if rel.extension().is_some_and(|x| x == "md") {
                out.push(rel);
            }
        }
    }
    out.sort();
    out
}

fn read(rel: &Path) -> String {
    fs::read_to_string(root().join(rel))
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", rel.display()))
}

/// The lines of a page that are prose: fenced code blocks (``` or ~~~) are replaced by empty
/// lines, so line numbers stay those of the file.
fn prose_lines(text: &str) -> Vec<String> {
    let mut fence: Option<String> = None;
    let mut out = Vec::new();
    for line in text.lines() {
        let trimmed = line.trim_start();
        let marker: String = trimmed
            .chars()
            .take_while(|&c| c == '`' || c == '~')
            .collect();
        let is_fence =
            marker.len() >= 3 && marker.chars().all(|c| c == marker.chars().next().unwrap());
        match &fence {
            Some(open) => {
                // A fence closes with the same character, at least as long as the opening.
                if is_fence
                    && marker.starts_with(open.as_str())
                    && trimmed[marker.len()..].trim().is_empty()
                {
                    fence = None;
                }
                out.push(String::new());
            }
            None if is_fence => {
                fence = Some(marker);
                out.push(String::new());
            }
            None => out.push(line.to_string()),
        }
    }
    out
}

/// The line with its inline code spans blanked out (a run of N backticks closes with N).
fn without_code_spans(line: &str) -> String {
    let chars: Vec<char> = line.chars().collect();
    let mut out = String::with_capacity(line.len());
    let mut i = 0;
    while i < chars.len() {
        if chars[i] != '`' {
            out.push(chars[i]);
            i += 1;
            continue;
        }
        let mut n = 0;
        while i + n < chars.len() && chars[i + n] == '`' {
            n += 1;
        }
        // Find the closing run of exactly n backticks.
        let mut j = i + n;
        let mut close = None;
        while j < chars.len() {
            if chars[j] == '`' {
                let mut m = 0;
                while j + m < chars.len() && chars[j + m] == '`' {
                    m += 1;
                }
                if m == n {
                    close = Some(j + m);
                    break;
                }
                j += m;
            } else {
                j += 1;
            }
        }
        match close {
            Some(end) => {
                out.extend(std::iter::repeat_n(' ', end - i));
                i = end;
            }
            // An unmatched run is literal text.
            None => {
                out.extend(std::iter::repeat_n('`', n));
                i += n;
            }
        }
    }
    out
}

/// The targets of the inline links and images on one prose line: what stands between `](` and
/// its matching `)`, without an optional title (`"..."`) and angle brackets (`<...>`).
fn inline_targets(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = line;
    while let Some(at) = rest.find("](") {
        let after = &rest[at + 2..];
        let mut depth = 0usize;
        let mut end = None;
        for (k, c) in after.char_indices() {
            match c {
                '(' => depth += 1,
                ')' if depth == 0 => {
                    end = Some(k);
                    break;
                }
                ')' => depth -= 1,
                _ => {}
            }
        }
        let Some(end) = end else { break };
        out.push(clean_target(&after[..end]));
        rest = &after[end + 1..];
    }
    out
}

/// A reference definition `[label]: target "title"` (at most three spaces of indent).
fn definition_target(line: &str) -> Option<String> {
    let indent = line.len() - line.trim_start_matches(' ').len();
    let t = line.trim_start();
    if indent > 3 || !t.starts_with('[') || t.starts_with("[^") {
        return None;
    }
    let close = t.find("]:")?;
    Some(clean_target(&t[close + 2..]))
}

fn clean_target(raw: &str) -> String {
    let t = raw.trim();
    if let Some(inner) = t.strip_prefix('<') {
        return inner.split('>').next().unwrap_or("").to_string();
    }
    // A title follows the target after whitespace.
    t.split_whitespace().next().unwrap_or("").to_string()
}

fn is_external(target: &str) -> bool {
    ["http://", "https://", "mailto:"]
        .iter()
        .any(|p| target.starts_with(p))
}

/// The heading slug of GitHub and mdBook: lowercase, whitespace to '-', characters other than
/// letters, digits, '-' and '_' dropped. Inline links count by their text; `{#id}` sets the id.
fn slug(heading: &str) -> String {
    let heading = heading.trim();
    if let Some(open) = heading.rfind("{#")
        && heading.ends_with('}')
    {
        return heading[open + 2..heading.len() - 1].to_string();
    }
    // [text](target) -> text
    let mut text = String::new();
    let mut rest = heading;
    while let Some(open) = rest.find('[') {
        text.push_str(&rest[..open]);
        let after = &rest[open + 1..];
        match (after.find("]("), after.find(')')) {
            (Some(close), Some(paren)) if paren > close => {
                text.push_str(&after[..close]);
                rest = &after[paren + 1..];
            }
            _ => {
                text.push('[');
                rest = after;
            }
        }
    }
    text.push_str(rest);
    text.chars()
        .filter_map(|c| {
            if c.is_alphanumeric() || c == '-' || c == '_' {
                Some(c.to_lowercase().collect::<String>())
            } else if c.is_whitespace() {
                Some("-".to_string())
            } else {
                None
            }
        })
        .collect()
}

/// The anchors of a page: the slugs of its ATX headings (`#` to `######`) outside code blocks,
/// repeated slugs numbered as GitHub and mdBook number them.
fn anchors(text: &str) -> BTreeSet<String> {
    let mut seen: HashMap<String, usize> = HashMap::new();
    let mut out = BTreeSet::new();
    for line in prose_lines(text) {
        let t = line.trim_start();
        let hashes = t.chars().take_while(|&c| c == '#').count();
        if hashes == 0 || hashes > 6 || line.len() - t.len() > 3 {
            continue;
        }
        let body = &t[hashes..];
        if !(body.is_empty() || body.starts_with(' ') || body.starts_with('\t')) {
            continue;
        }
        // Closing hashes are not part of the heading.
        let body = body.trim().trim_end_matches('#').trim_end();
        let base = slug(body);
        let n = seen.entry(base.clone()).or_insert(0);
        out.insert(if *n == 0 {
            base.clone()
        } else {
            format!("{base}-{n}")
        });
        *n += 1;
    }
    out
}

/// `a/b/../c` -> `a/c`, so a target can be compared with the listed pages.
fn normalise(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for part in path.components() {
        match part {
            Component::CurDir => {}
            Component::ParentDir => {
                if !out.pop() {
                    out.push("..");
                }
            }
            other => out.push(other),
        }
    }
    out
}

/// Checks every link of every page; returns one message per failure.
fn link_failures() -> Vec<String> {
    let mut failures = Vec::new();
    let mut anchor_cache: HashMap<PathBuf, BTreeSet<String>> = HashMap::new();
    for page in pages() {
        let text = read(&page);
        let dir = page.parent().unwrap_or(Path::new("")).to_path_buf();
        for (i, line) in prose_lines(&text).iter().enumerate() {
            let line = without_code_spans(line);
            let mut targets = inline_targets(&line);
            targets.extend(definition_target(&line));
            for target in targets {
                let at = format!("{}:{}: link `{target}`", page.display(), i + 1);
                if is_external(&target) {
                    continue;
                }
                if target.is_empty() {
                    failures.push(format!("{at}: empty target"));
                    continue;
                }
                if target.starts_with('/') || target.contains("://") {
                    failures.push(format!("{at}: not a relative link"));
                    continue;
                }
                let (file, anchor) = match target.split_once('#') {
                    Some((f, a)) => (f, Some(a)),
                    None => (target.as_str(), None),
                };
                // A link to `#anchor` alone points into the page itself.
                let resolved = if file.is_empty() {
                    page.clone()
                } else {
                    normalise(&dir.join(file))
                };
                if !root().join(&resolved).exists() {
                    failures.push(format!("{at}: {} does not exist", resolved.display()));
                    continue;
                }
                let Some(anchor) = anchor else { continue };
                if resolved.extension().is_none_or(|x| x != "md") {
                    continue;
                }
                let known = anchor_cache
                    .entry(resolved.clone())
                    .or_insert_with(|| anchors(&read(&resolved)));
                if !known.contains(anchor) {
                    failures.push(format!(
                        "{at}: no heading `#{anchor}` in {}",
                        resolved.display()
                    ));
                }
            }
        }
    }
    failures
}

#[test]
fn every_relative_link_and_image_resolves() {
    let failures = link_failures();
    assert!(
        failures.is_empty(),
        "{} broken link(s) in README.md and docs/:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

#[test]
fn summary_lists_every_page_and_only_pages_that_exist() {
    let summary = PathBuf::from("docs/SUMMARY.md");
    let mut listed = BTreeSet::new();
    let mut failures = Vec::new();
    for (i, line) in prose_lines(&read(&summary)).iter().enumerate() {
        for target in inline_targets(&without_code_spans(line)) {
            let file = target.split('#').next().unwrap_or("");
            let page = normalise(&Path::new("docs").join(file));
            if file.is_empty() || !root().join(&page).is_file() {
                failures.push(format!(
                    "docs/SUMMARY.md:{}: chapter `{target}` is not a page",
                    i + 1
                ));
            }
            listed.insert(page);
        }
    }
    for page in pages() {
        if page.starts_with("docs") && page != summary && !listed.contains(&page) {
            failures.push(format!(
                "{}: not listed in docs/SUMMARY.md (mdBook would not build it)",
                page.display()
            ));
        }
    }
    assert!(
        failures.is_empty(),
        "docs/SUMMARY.md:\n{}",
        failures.join("\n")
    );
}

#[test]
fn the_book_config_keeps_its_source_in_docs() {
    let config = read(Path::new("docs/book.toml"));
    let src = config
        .lines()
        .map(|l| l.split('#').next().unwrap_or("").replace(' ', ""))
        .any(|l| l == "src=\".\"");
    assert!(
        src,
        "docs/book.toml: the book's source must be docs/ itself (src = \".\")"
    );
}

#[test]
fn the_readme_is_a_front_door() {
    let lines = read(Path::new("README.md")).lines().count();
    assert!(
        lines < 300,
        "README.md: {lines} lines; keep it under 300 and move detail into docs/"
    );
}

/// The helpers themselves, on the cases the pages use.
#[test]
fn slugs_links_and_code_follow_the_markdown_rules() {
    assert_eq!(
        slug("Overrides from the command line: `--set`"),
        "overrides-from-the-command-line---set"
    );
    assert_eq!(
        slug("A coupled run's Poisson's ratio is at most 0.48"),
        "a-coupled-runs-poissons-ratio-is-at-most-048"
    );
    assert_eq!(slug("`fluid`, `initial_fluid`"), "fluid-initial_fluid");
    assert_eq!(
        slug("See [the book](docs/SUMMARY.md) now"),
        "see-the-book-now"
    );
    assert_eq!(slug("Custom {#my-id}"), "my-id");
    let a = anchors("# T\n## Limits\n```\n## Not a heading\n```\n## Limits\n");
    assert!(
        a.contains("limits") && a.contains("limits-1") && !a.contains("not-a-heading"),
        "{a:?}"
    );
    assert_eq!(
        inline_targets("![x](a.png) and [y](b.md#c \"title\") and [z](<d e.md>) and f(x)"),
        vec!["a.png", "b.md#c", "d e.md"]
    );
    assert_eq!(inline_targets("[rs](x(1).rs)"), vec!["x(1).rs"]);
    assert!(inline_targets(&without_code_spans("`[a](missing.md)` and ``[b](c)``")).is_empty());
    assert_eq!(
        definition_target("[ref]: ../x.md \"t\"").as_deref(),
        Some("../x.md")
    );
    assert_eq!(
        normalise(Path::new("docs/../systems/./src/lib.rs")),
        PathBuf::from("systems/src/lib.rs")
    );
}
