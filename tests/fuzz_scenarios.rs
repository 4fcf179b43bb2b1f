//! Mutation fuzzing of the scenario parser and validation (README "Reliability").
//!
//! Seeds: the shipped scenarios (`scenarios/*.ron`) and the bad-input corpus of
//! `tests/bad_inputs.rs` (its text edits applied to the scenarios they name, its small scene, its
//! `--set` overrides, and every string literal of the file as a dictionary of tokens). A seeded
//! ChaCha8 fuzzer mutates them: tokens deleted, duplicated, swapped or replaced by dictionary
//! tokens, numbers replaced by extreme values (0, -1, 1e308, -1e-308, NaN, inf, huge integers),
//! truncation, random bytes and unicode, field names changed, values nested deeply, `--set`
//! overrides with extreme values.
//!
//! Each input goes through `Scenario::parse`, `with_overrides`, `validate`, the memory estimate
//! (`resources::check`) and, when the estimate is small (64 MiB) and the scene passed, a
//! `Simulation` with `time.max_steps = 3` run to its end. Required: no panic (caught and
//! reported with the input), every error one non-empty line, every input within the time limit
//! (a worker thread; a hang is reported with the input), finite state after a run that
//! succeeded, and no file created in the crate or the working folder.
//!
//! `tests/fuzz_regressions/*.ron`: inputs that once failed, always run (lines `//! set P=V`
//! at the top are overrides). CI: `inputs_within_budget` (2,000 inputs or 20 s). On demand:
//! `HYDROFRAC_FUZZ_N=100000 cargo test --release --test fuzz_scenarios -- --ignored`
//! (`HYDROFRAC_FUZZ_SEED` picks the seed, default 1); a failing input is written to
//! `target/fuzz-findings/`.

use hydrofrac::scenario::Scenario;
use hydrofrac::sim::Simulation;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// Longest time one input may take (parse, validate, estimate, a 3-step run).
const INPUT_LIMIT: Duration = Duration::from_secs(10);
/// Memory estimate under which a valid scene is also set up and run (bytes).
const RUN_LIMIT: u64 = 64 << 20;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// One fuzz input: scenario text and `--set` overrides.
#[derive(Clone, Debug)]
struct Input {
    text: String,
    sets: Vec<String>,
}

impl Input {
    /// As a regression file: the overrides as `//! set` lines, then the text.
    fn to_file(&self) -> String {
        let mut s = String::new();
        for set in &self.sets {
            s += &format!("//! set {}\n", set.replace('\n', " "));
        }
        s + &self.text
    }
    fn from_file(file: &str) -> Input {
        let sets = file
            .lines()
            .map_while(|l| l.strip_prefix("//! set "))
            .map(str::to_string)
            .collect();
        Input {
            text: file.to_string(),
            sets,
        }
    }
}

/// What came of one input (for the figures).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Outcome {
    SyntaxError,
    OverrideError,
    Invalid,
    TooLarge,
    Valid,
    SetupError,
    Ran,
    RunError,
}

/// Parse, override, validate, estimate, and for a small valid scene run 3 steps. `Err`: a
/// defect (panic, multi-line or empty message, non-finite state).
fn check_input(input: &Input) -> Result<Outcome, String> {
    let one_line = |stage: &str, msg: String| -> Result<(), String> {
        if msg.trim().is_empty() || msg.contains('\n') || msg.contains('\r') {
            Err(format!("{stage}: error is not one non-empty line: {msg:?}"))
        } else {
            Ok(())
        }
    };
    let go = || -> Result<Outcome, String> {
        let sc = match Scenario::parse(&input.text, "fuzz.ron") {
            Ok(sc) => sc,
            Err(e) => {
                one_line("parse", e.to_string())?;
                return Ok(Outcome::SyntaxError);
            }
        };
        let sc = if input.sets.is_empty() {
            sc
        } else {
            match sc.with_overrides(&input.sets) {
                Ok(sc) => sc,
                Err(e) => {
                    one_line("--set", e.to_string())?;
                    return Ok(Outcome::OverrideError);
                }
            }
        };
        let sc = match sc.validate() {
            Ok(sc) => sc,
            Err(e) => {
                one_line("validate", e.to_string())?;
                return Ok(Outcome::Invalid);
            }
        };
        let (limit, source) = hydrofrac::resources::default_limit();
        if let Err(e) = hydrofrac::resources::check(&sc, limit, &source) {
            one_line("memory", e.to_string())?;
            return Ok(Outcome::TooLarge);
        }
        if hydrofrac::resources::check(&sc, RUN_LIMIT, "fuzz").is_err() {
            return Ok(Outcome::Valid);
        }
        // Edited for a short run: a new scenario, validated again.
        let sc = match sc.with_overrides(&["time.max_steps=3".to_string()]) {
            Ok(sc) => sc,
            Err(e) => {
                one_line("--set time.max_steps", e.to_string())?;
                return Ok(Outcome::Valid);
            }
        };
        // A valid scene with max_steps 3 may now break `min_steps <= max_steps`: refused.
        let sc = match sc.validate() {
            Ok(sc) => sc,
            Err(e) => {
                one_line("validate (max_steps 3)", e.to_string())?;
                return Ok(Outcome::Valid);
            }
        };
        let mut sim = match Simulation::new(sc, &[]) {
            Ok(s) => s,
            Err(e) => {
                one_line("setup", e.to_string())?;
                return Ok(Outcome::SetupError);
            }
        };
        match sim.run(|_| {}) {
            Ok(_) => {
                let v = sim.series_values();
                if let Some(k) = v.iter().position(|x| !x.is_finite()) {
                    return Err(format!(
                        "run: time-series column {} = {} after a successful run",
                        sim.series_columns()[k],
                        v[k]
                    ));
                }
                let s = sim.solid();
                if s.u.iter().chain(&s.v).flatten().any(|x| !x.is_finite())
                    || s.stress.iter().flatten().any(|x| !x.is_finite())
                {
                    return Err("run: non-finite displacement, velocity or stress".into());
                }
                Ok(Outcome::Ran)
            }
            Err(e) => {
                one_line("run", e.to_string())?;
                Ok(Outcome::RunError)
            }
        }
    };
    match catch_unwind(AssertUnwindSafe(go)) {
        Ok(r) => r,
        Err(p) => Err(format!(
            "panic: {}",
            p.downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| p.downcast_ref::<&str>().copied())
                .unwrap_or("(no message)")
        )),
    }
}

// ---------------------------------------------------------------------------------------------
// Seeds.

/// The string literals of Rust source (plain with escapes, and raw `r#"..."#`), in order.
fn string_literals(src: &str) -> Vec<String> {
    let b = src.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        // Skip line comments (they hold quotes of their own).
        if b[i] == b'/' && b.get(i + 1) == Some(&b'/') {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
            continue;
        }
        if b[i] == b'\'' {
            // A char literal such as '"' or '\n' (lifetimes are not in this file's strings).
            if let Some(j) = src[i + 1..].find('\'')
                && j <= 10
            {
                i += j + 2;
                continue;
            }
        }
        if b[i] == b'r' && (b.get(i + 1) == Some(&b'#') || b.get(i + 1) == Some(&b'"')) {
            let hashes = b[i + 1..].iter().take_while(|&&c| c == b'#').count();
            if b.get(i + 1 + hashes) == Some(&b'"') {
                let start = i + 2 + hashes;
                let close = format!("\"{}", "#".repeat(hashes));
                if let Some(len) = src[start..].find(&close) {
                    out.push(src[start..start + len].to_string());
                    i = start + len + close.len();
                    continue;
                }
            }
        }
        if b[i] == b'"' {
            let mut s = String::new();
            let mut chars = src[i + 1..].char_indices();
            let mut end = None;
            while let Some((k, c)) = chars.next() {
                match c {
                    '"' => {
                        end = Some(i + 1 + k + 1);
                        break;
                    }
                    '\\' => match chars.next() {
                        Some((_, 'n')) => s.push('\n'),
                        Some((_, 't')) => s.push('\t'),
                        Some((_, '0')) => s.push('\0'),
                        Some((_, 'u')) => {
                            let mut hex = String::new();
                            for (_, c) in chars.by_ref() {
                                match c {
                                    '{' => {}
                                    '}' => break,
                                    c => hex.push(c),
                                }
                            }
                            if let Some(c) =
                                u32::from_str_radix(&hex, 16).ok().and_then(char::from_u32)
                            {
                                s.push(c);
                            }
                        }
                        Some((_, '\n')) => {
                            // A line continuation: skip the next line's leading blanks.
                            let rest = chars.as_str();
                            let skip = rest.len() - rest.trim_start().len();
                            for _ in 0..rest[..skip].chars().count() {
                                chars.next();
                            }
                        }
                        Some((_, c)) => s.push(c),
                        None => {}
                    },
                    c => s.push(c),
                }
            }
            match end {
                Some(e) => {
                    out.push(s);
                    i = e;
                }
                None => break,
            }
            continue;
        }
        i += 1;
    }
    out
}

/// The seed inputs and the dictionary of tokens.
struct Corpus {
    seeds: Vec<Input>,
    dict: Vec<String>,
    /// `PATH=VALUE` overrides of the bad-input corpus and the valid paths seen.
    sets: Vec<String>,
    paths: Vec<String>,
}

fn corpus() -> Corpus {
    let mut scenes: Vec<(String, String)> = Vec::new();
    let mut names: Vec<PathBuf> = std::fs::read_dir(root().join("scenarios"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "ron"))
        .collect();
    names.sort();
    for p in &names {
        let name = p.file_name().unwrap().to_string_lossy().to_string();
        scenes.push((name, std::fs::read_to_string(p).unwrap()));
    }
    assert!(scenes.len() >= 8, "{} shipped scenarios", scenes.len());
    let src = std::fs::read_to_string(root().join("tests/bad_inputs.rs")).unwrap();
    let lits = string_literals(&src);
    let mut seeds: Vec<Input> = scenes
        .iter()
        .map(|(_, t)| Input {
            text: t.clone(),
            sets: vec![],
        })
        .collect();
    // Whole texts of the corpus (its small scene, its files).
    for l in &lits {
        if l.trim_start().starts_with('(') && l.contains("name") {
            seeds.push(Input {
                text: l.clone(),
                sets: vec![],
            });
        }
    }
    // Its edits: a literal pair (from, to) where `from` occurs in a scene.
    for w in lits.windows(2) {
        for (_, t) in &scenes {
            if w[0].len() >= 3 && t.contains(w[0].as_str()) {
                seeds.push(Input {
                    text: t.replacen(w[0].as_str(), &w[1], 1),
                    sets: vec![],
                });
                break;
            }
        }
    }
    let sets: Vec<String> = lits
        .iter()
        .filter(|l| l.contains('=') && !l.contains(' ') && !l.starts_with('-'))
        .cloned()
        .collect();
    let mut dict: Vec<String> = lits.iter().filter(|l| l.len() <= 80).cloned().collect();
    // Identifiers and numbers of the scenes.
    for (_, t) in &scenes {
        for tok in tokens(t) {
            if tok.chars().next().is_some_and(|c| c.is_alphanumeric()) && tok.len() <= 40 {
                dict.push(tok.to_string());
            }
        }
    }
    dict.sort();
    dict.dedup();
    // Override paths: every field path of the parsed scenes (JSON of the scenario).
    let mut paths = Vec::new();
    for (_, t) in &scenes {
        if let Ok(sc) = Scenario::parse(t, "seed") {
            let v = serde_json::to_value(&sc).unwrap();
            collect_paths(&v, String::new(), &mut paths);
        }
    }
    paths.sort();
    paths.dedup();
    Corpus {
        seeds,
        dict,
        sets,
        paths,
    }
}

fn collect_paths(v: &serde_json::Value, prefix: String, out: &mut Vec<String>) {
    if let serde_json::Value::Object(m) = v {
        for (k, x) in m {
            // Enum variant wrappers are stepped through by the override path itself.
            let p = if k.starts_with(|c: char| c.is_ascii_uppercase()) {
                prefix.clone()
            } else if prefix.is_empty() {
                k.clone()
            } else {
                format!("{prefix}.{k}")
            };
            if !p.is_empty() {
                out.push(p.clone());
            }
            collect_paths(x, p, out);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Mutations.

/// Split text into tokens: identifiers/numbers, strings, single punctuation, runs of blanks.
fn tokens(text: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let mut it = text.char_indices().peekable();
    while let Some((i, c)) = it.next() {
        let mut end = i + c.len_utf8();
        if c.is_alphanumeric() || c == '_' || c == '.' || c == '-' || c == '+' {
            while let Some(&(j, d)) = it.peek() {
                if d.is_alphanumeric() || d == '_' || d == '.' || d == '-' || d == '+' {
                    end = j + d.len_utf8();
                    it.next();
                } else {
                    break;
                }
            }
        } else if c == '"' {
            for (j, d) in it.by_ref() {
                end = j + d.len_utf8();
                if d == '"' {
                    break;
                }
            }
        } else if c.is_whitespace() {
            while let Some(&(j, d)) = it.peek() {
                if d.is_whitespace() {
                    end = j + d.len_utf8();
                    it.next();
                } else {
                    break;
                }
            }
        }
        out.push(&text[i..end]);
    }
    out
}

const EXTREMES: &[&str] = &[
    "0",
    "0.0",
    "-0.0",
    "-1",
    "-1.0",
    "1e308",
    "-1e308",
    "1e-308",
    "-1e-308",
    "5e-324",
    "1e309",
    "NaN",
    "inf",
    "-inf",
    "+inf",
    "18446744073709551615",
    "18446744073709551616",
    "-9223372036854775808",
    "99999999999999999999999999999",
    "4294967296",
    "1e15",
    "1e-15",
    "0.5",
    "0.49999999",
    "1",
    "2",
    "3",
    "1e6",
    "1e9",
];

const NOISE: &[&str] = &[
    "\u{0}",
    "\u{feff}",
    "\u{202e}",
    "é",
    "日本",
    "🦀",
    "\u{10ffff}",
    "\\",
    "\"",
    "'",
    "/*",
    "*/",
    "//",
    "#",
    "r#\"",
    "b\"",
    "\n",
    "\r\n",
    "\t",
    "..",
    ":",
    ",",
    "(",
    ")",
    "[",
    "]",
    "{",
    "}",
    "Some(",
    "None",
    "true",
    "()",
    "[]",
    "/..",
    "../../etc/passwd",
    "/tmp/x",
];

fn pick<'a, T>(rng: &mut ChaCha8Rng, v: &'a [T]) -> &'a T {
    &v[rng.random_range(0..v.len())]
}

fn is_number(t: &str) -> bool {
    t.parse::<f64>().is_ok() || t.starts_with(|c: char| c.is_ascii_digit())
}

/// One mutation of `input` (kind chosen at random).
fn mutate(rng: &mut ChaCha8Rng, c: &Corpus, input: &Input) -> Input {
    let mut out = input.clone();
    let toks: Vec<String> = tokens(&input.text).iter().map(|s| s.to_string()).collect();
    let n = toks.len().max(1);
    let mut toks = toks;
    if toks.is_empty() {
        toks.push(String::new());
    }
    let k = rng.random_range(0..n);
    match rng.random_range(0..13) {
        // Delete a token (or a run of them).
        0 => {
            let len = rng.random_range(1..=4).min(n - k);
            toks.drain(k..k + len);
        }
        // Duplicate one.
        1 => {
            let t = toks[k].clone();
            toks.insert(k, t);
        }
        // Swap two.
        2 => {
            let j = rng.random_range(0..n);
            toks.swap(k, j);
        }
        // A number by an extreme value.
        3 | 4 => {
            let nums: Vec<usize> = (0..toks.len()).filter(|&i| is_number(&toks[i])).collect();
            let i = if nums.is_empty() {
                k
            } else {
                *pick(rng, &nums)
            };
            toks[i] = pick(rng, EXTREMES).to_string();
        }
        // Truncate.
        5 => {
            toks.truncate(k);
        }
        // Random bytes or unicode.
        6 => {
            let s = if rng.random_bool(0.5) {
                pick(rng, NOISE).to_string()
            } else {
                let len = rng.random_range(1..8);
                (0..len)
                    .map(|_| char::from_u32(rng.random_range(0..0x3000)).unwrap_or('?'))
                    .collect()
            };
            toks.insert(k, s);
        }
        // A field name or token replaced by a dictionary one.
        7 | 8 => {
            let idents: Vec<usize> = (0..toks.len())
                .filter(|&i| toks[i].starts_with(|ch: char| ch.is_alphabetic()))
                .collect();
            let i = if idents.is_empty() {
                k
            } else {
                *pick(rng, &idents)
            };
            toks[i] = pick(rng, &c.dict).clone();
        }
        // Nesting: wrap a token in brackets, Some(...), or deeply.
        9 => {
            let depth = if rng.random_bool(0.1) {
                rng.random_range(100..20_000)
            } else {
                rng.random_range(1..4)
            };
            let (open, close) = *pick(rng, &[("(", ")"), ("[", "]"), ("Some(", ")"), ("{", "}")]);
            toks[k] = format!("{}{}{}", open.repeat(depth), toks[k], close.repeat(depth));
        }
        // A `--set` override: from the corpus, or a field path with an extreme value.
        10 => {
            let s = if rng.random_bool(0.3) && !c.sets.is_empty() {
                pick(rng, &c.sets).clone()
            } else {
                let v = match rng.random_range(0..4) {
                    0 => pick(rng, EXTREMES).to_string(),
                    1 => pick(rng, &c.dict).clone(),
                    2 => "null".into(),
                    _ => format!("[{}, {}]", pick(rng, EXTREMES), pick(rng, EXTREMES)),
                };
                format!("{}={v}", pick(rng, &c.paths))
            };
            out.sets.push(s);
        }
        // Noise inside a string (a name, a file, a system): control characters, quotes.
        11 => {
            let strs: Vec<usize> = (0..toks.len())
                .filter(|&i| toks[i].len() >= 2 && toks[i].starts_with('"'))
                .collect();
            if !strs.is_empty() {
                let i = *pick(rng, &strs);
                let inner = &toks[i][1..toks[i].len() - 1];
                let cut = (0..=inner.len())
                    .filter(|&j| inner.is_char_boundary(j))
                    .nth(rng.random_range(0..=inner.chars().count()))
                    .unwrap_or(0);
                let noise = *pick(
                    rng,
                    &[
                        "\\n",
                        "\\r",
                        "\\t",
                        "\\u{0}",
                        "\\u{1b}[31m",
                        "\\\"",
                        "\n",
                        "\u{7}",
                    ],
                );
                toks[i] = format!("\"{}{noise}{}\"", &inner[..cut], &inner[cut..]);
            }
        }
        // Splice: a run of tokens from another seed.
        _ => {
            let other = tokens(&pick(rng, &c.seeds).text)
                .iter()
                .map(|s| s.to_string())
                .collect::<Vec<_>>();
            if !other.is_empty() {
                let a = rng.random_range(0..other.len());
                let b = (a + rng.random_range(1..20)).min(other.len());
                for (j, t) in other[a..b].iter().enumerate() {
                    toks.insert((k + j).min(toks.len()), t.clone());
                }
            }
        }
    }
    out.text = toks.concat();
    out
}

// ---------------------------------------------------------------------------------------------
// The driver.

/// Figures of a fuzz run.
#[derive(Debug, Default)]
struct Figures {
    inputs: usize,
    outcomes: std::collections::BTreeMap<String, usize>,
    slowest: Duration,
    findings: Vec<String>,
}

/// Entries of the crate's root and `scenarios/`, and of the working folder, to see that no
/// input made a file.
fn listing() -> Vec<PathBuf> {
    let mut v = Vec::new();
    for d in [
        root(),
        root().join("scenarios"),
        std::env::current_dir().unwrap(),
    ] {
        if let Ok(rd) = std::fs::read_dir(&d) {
            v.extend(rd.map(|e| e.unwrap().path()));
        }
    }
    v.sort();
    v.dedup();
    v
}

/// Keep a failing input where it can be turned into a regression case.
fn keep(input: &Input, k: usize) -> PathBuf {
    let dir = root().join("target/fuzz-findings");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("finding_{k}.ron"));
    std::fs::write(&path, input.to_file()).unwrap();
    path
}

/// Run `inputs` (an iterator) through [`check_input`] on a worker thread, each within
/// [`INPUT_LIMIT`]. The first `untimed` inputs always run; after them, inputs run until `budget`
/// (counted from the first input after them) is spent. A hang ends the run (the worker is left
/// behind).
fn fuzz(inputs: impl Iterator<Item = Input>, untimed: usize, budget: Duration) -> Figures {
    let (tx_in, rx_in) = mpsc::channel::<Input>();
    let (tx_out, rx_out) = mpsc::channel::<(Result<Outcome, String>, Duration)>();
    std::thread::Builder::new()
        .name("fuzz-worker".into())
        // The main thread's stack on Linux (8 MiB): what the binary parses with.
        .stack_size(8 << 20)
        .spawn(move || {
            for input in rx_in {
                let t0 = Instant::now();
                let r = check_input(&input);
                if tx_out.send((r, t0.elapsed())).is_err() {
                    break;
                }
            }
        })
        .unwrap();
    let prev_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let before = listing();
    let mut fig = Figures::default();
    let mut t0 = Instant::now();
    for (k, input) in inputs.enumerate() {
        if k == untimed {
            t0 = Instant::now();
        }
        if k >= untimed && t0.elapsed() > budget {
            break;
        }
        tx_in.send(input.clone()).unwrap();
        fig.inputs += 1;
        match rx_out.recv_timeout(INPUT_LIMIT) {
            Ok((r, dt)) => {
                fig.slowest = fig.slowest.max(dt);
                match r {
                    Ok(o) => *fig.outcomes.entry(format!("{o:?}")).or_default() += 1,
                    Err(why) => {
                        let p = keep(&input, fig.findings.len());
                        fig.findings
                            .push(format!("{why} (input in {})", p.display()));
                    }
                }
            }
            Err(_) => {
                let p = keep(&input, fig.findings.len());
                fig.findings.push(format!(
                    "no answer within {INPUT_LIMIT:?} (input in {})",
                    p.display()
                ));
                break;
            }
        }
        if fig.findings.len() >= 20 {
            break;
        }
    }
    std::panic::set_hook(prev_hook);
    let after = listing();
    for p in after.iter().filter(|p| !before.contains(p)) {
        if !p.ends_with("target") {
            fig.findings.push(format!("created {}", p.display()));
        }
    }
    fig
}

/// Inputs: first every seed and regression, then mutants (1 to 4 mutations of a seed).
fn stream(c: &Corpus, seed: u64, regressions: Vec<Input>) -> impl Iterator<Item = Input> + '_ {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let fixed: Vec<Input> = regressions
        .into_iter()
        .chain(c.seeds.iter().cloned())
        .collect();
    fixed.into_iter().chain(std::iter::from_fn(move || {
        let mut x = pick(&mut rng, &c.seeds).clone();
        for _ in 0..rng.random_range(1..=4) {
            x = mutate(&mut rng, c, &x);
        }
        Some(x)
    }))
}

fn regressions() -> Vec<(PathBuf, Input)> {
    let dir = root().join("tests/fuzz_regressions");
    let mut v: Vec<(PathBuf, Input)> = std::fs::read_dir(&dir)
        .map(|rd| {
            rd.map(|e| e.unwrap().path())
                .filter(|p| p.extension().is_some_and(|e| e == "ron"))
                .map(|p| {
                    let text = std::fs::read(&p).unwrap();
                    let input = Input::from_file(&String::from_utf8_lossy(&text));
                    (p, input)
                })
                .collect()
        })
        .unwrap_or_default();
    v.sort_by(|a, b| a.0.cmp(&b.0));
    v
}

fn report(what: &str, fig: &Figures, wall: Duration) {
    eprintln!(
        "{what}: {} inputs in {:.1} s ({:.0} per second), slowest {:.3} s, outcomes {:?}, {} findings",
        fig.inputs,
        wall.as_secs_f64(),
        fig.inputs as f64 / wall.as_secs_f64(),
        fig.slowest.as_secs_f64(),
        fig.outcomes,
        fig.findings.len()
    );
}

/// The run found nothing; else every finding, with where its input is kept.
fn assert_no_findings(fig: &Figures) {
    assert!(
        fig.findings.is_empty(),
        "{} findings:\n{}",
        fig.findings.len(),
        fig.findings.join("\n")
    );
}

/// Every input that once failed, alone: no panic, one-line errors, in time.
#[test]
fn regression_inputs_pass() {
    let reg = regressions();
    let mut failures = Vec::new();
    for (path, input) in &reg {
        let fig = fuzz(std::iter::once(input.clone()), 1, Duration::ZERO);
        for f in &fig.findings {
            failures.push(format!("{}: {f}", path.display()));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// CI: every regression input and corpus seed (each within [`INPUT_LIMIT`]), then their mutants,
/// up to 2,000 inputs in all or 5 s of mutants, whichever comes first. Only the number of
/// mutants depends on the machine's speed; what is asserted does not.
#[test]
fn inputs_within_budget() {
    let c = corpus();
    let reg: Vec<Input> = regressions().into_iter().map(|r| r.1).collect();
    let fixed = reg.len() + c.seeds.len();
    let t0 = Instant::now();
    let fig = fuzz(
        stream(&c, 1, reg).take(2_000),
        fixed,
        Duration::from_secs(5),
    );
    report("fuzz (CI)", &fig, t0.elapsed());
    assert_no_findings(&fig);
    assert!(
        fig.inputs >= fixed,
        "only {} of the {fixed} regression and seed inputs ran (a hang?)",
        fig.inputs
    );
    assert!(
        fig.outcomes.get("Ran").copied().unwrap_or(0) > 0,
        "no input was run: {:?}",
        fig.outcomes
    );
}

/// On demand: `HYDROFRAC_FUZZ_N` inputs (default 100,000), seed `HYDROFRAC_FUZZ_SEED`.
#[test]
#[ignore]
fn long_fuzz_run() {
    let n: usize = std::env::var("HYDROFRAC_FUZZ_N")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(100_000);
    let seed: u64 = std::env::var("HYDROFRAC_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    let c = corpus();
    let reg: Vec<Input> = regressions().into_iter().map(|r| r.1).collect();
    let t0 = Instant::now();
    let fig = fuzz(stream(&c, seed, reg).take(n), n, Duration::ZERO);
    report(&format!("fuzz (seed {seed})"), &fig, t0.elapsed());
    assert_no_findings(&fig);
}

/// The literal extractor reads the corpus: its small scene and `--set` overrides.
#[test]
fn the_corpus_is_read() {
    let c = corpus();
    assert!(c.seeds.len() > 50, "{} seeds", c.seeds.len());
    assert!(
        c.sets.iter().any(|s| s == "mesh.h=0"),
        "overrides: {:?}",
        &c.sets[..c.sets.len().min(10)]
    );
    assert!(c.paths.iter().any(|p| p == "material.poisson"));
    assert!(Path::new(&root().join("tests/bad_inputs.rs")).exists());
}

// ---------------------------------------------------------------------------------------------
// Through the binary, as a user runs it.

#[path = "support/finite.rs"]
mod finite;

/// Time a `hydrofrac run` gets before it is sent SIGTERM, and the time it then has to stop
/// (it must: the step loop and the production stage check the stop flag).
const BIN_LIMIT: Duration = Duration::from_secs(5);
const BIN_GRACE: Duration = Duration::from_secs(5);
/// Address space of a `hydrofrac run` (as on a cluster node or in a container): the memory
/// check must refuse what does not fit, never an allocation abort.
const BIN_MEMORY: u64 = 4 << 30;

/// What came of one input through the binary.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum BinOutcome {
    /// Exit 1 with a message (refused, or the run failed with its outputs kept).
    Refused,
    /// Exit 0.
    Ran,
    /// Stopped by the SIGTERM at `BIN_LIMIT` (exit 143, `summary.json` status `interrupted`).
    Interrupted,
    /// Ended by the SIGTERM during setup (exit 143), before its output folder existed.
    StoppedInSetup,
}

/// Run `input` as `hydrofrac run scene.ron --out out [--set ...] --quiet` in a folder of its
/// own under `work`, in a 4 GiB address space, with SIGTERM at [`BIN_LIMIT`] and SIGKILL
/// [`BIN_GRACE`] later. `Err`: a defect (killed by a signal of its own, e.g. SIGABRT; SIGTERM
/// not acted on; an exit status other than 0, 1 and 143; an empty message or a panic on
/// stderr; a non-finite token in the outputs; a file written outside `out`).
fn check_binary(input: &Input, work: &Path) -> Result<BinOutcome, String> {
    use std::os::unix::process::{CommandExt, ExitStatusExt};
    let _ = std::fs::remove_dir_all(work);
    std::fs::create_dir_all(work).map_err(|e| e.to_string())?;
    std::fs::write(work.join("scene.ron"), &input.text).map_err(|e| e.to_string())?;
    let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_hydrofrac"));
    cmd.current_dir(work)
        .args(["run", "scene.ron", "--out", "out", "--quiet"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped());
    for s in &input.sets {
        cmd.args(["--set", s]);
    }
    // SAFETY: setrlimit is async-signal-safe; the closure allocates nothing.
    unsafe {
        cmd.pre_exec(|| {
            let r = libc::rlimit {
                rlim_cur: BIN_MEMORY,
                rlim_max: BIN_MEMORY,
            };
            if libc::setrlimit(libc::RLIMIT_AS, &r) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    let mut child = cmd.spawn().map_err(|e| e.to_string())?;
    // Read stderr on a thread so that a chatty child never blocks on a full pipe.
    let mut err_pipe = child.stderr.take().expect("stderr");
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = std::io::Read::read_to_string(&mut err_pipe, &mut s);
        s
    });
    let t0 = Instant::now();
    let mut termed = false;
    let status = loop {
        if let Some(st) = child.try_wait().map_err(|e| e.to_string())? {
            break st;
        }
        let dt = t0.elapsed();
        if !termed && dt > BIN_LIMIT {
            // SAFETY: a signal to our own child.
            unsafe { libc::kill(child.id() as i32, libc::SIGTERM) };
            termed = true;
        }
        if dt > BIN_LIMIT + BIN_GRACE {
            let _ = child.kill();
            let _ = child.wait();
            return Err(format!(
                "SIGTERM not acted on within {} s",
                BIN_GRACE.as_secs()
            ));
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let stderr = reader.join().unwrap_or_default();
    if stderr.contains("panicked at") {
        return Err(format!("panic: {}", stderr.trim()));
    }
    let out = work.join("out");
    let outcome = match (status.code(), status.signal()) {
        (Some(0), _) => BinOutcome::Ran,
        (Some(1), _) if !stderr.trim().is_empty() => BinOutcome::Refused,
        (Some(1), _) => return Err("exit 1 without a message".into()),
        // Stopped during setup, before anything was written.
        (Some(143), _) if termed && !out.exists() => BinOutcome::StoppedInSetup,
        (Some(143), _) if termed => {
            let s = std::fs::read_to_string(out.join("summary.json")).unwrap_or_default();
            if !s.contains("\"interrupted\"") {
                return Err(format!("exit 143 without an interrupted summary: {s:.200}"));
            }
            BinOutcome::Interrupted
        }
        (Some(c), _) => return Err(format!("exit status {c}: {}", stderr.trim())),
        (None, Some(sig)) => {
            return Err(format!("killed by signal {sig}: {}", stderr.trim()));
        }
        (None, None) => return Err("no exit status".into()),
    };
    if out.is_dir() {
        let bad = finite::non_finite_tokens(&out);
        if !bad.is_empty() {
            return Err(format!("{outcome:?} with non-finite output: {bad:?}"));
        }
    }
    let mut extra: Vec<String> = std::fs::read_dir(work)
        .map_err(|e| e.to_string())?
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .filter(|n| n != "scene.ron" && n != "out")
        .collect();
    extra.sort();
    if !extra.is_empty() {
        return Err(format!(
            "{outcome:?}, and wrote outside its folder: {extra:?}"
        ));
    }
    Ok(outcome)
}

/// Run `inputs` through [`check_binary`] on `workers` threads; stop at `budget` (wall time)
/// or 20 findings. Each worker has its folder under `target/fuzz-bin/`, emptied per input.
fn fuzz_binary(
    inputs: impl Iterator<Item = Input> + Send,
    workers: usize,
    budget: Duration,
) -> Figures {
    let inputs = std::sync::Mutex::new(inputs);
    let fig = std::sync::Mutex::new(Figures::default());
    let t0 = Instant::now();
    let before = listing();
    std::thread::scope(|s| {
        for w in 0..workers {
            let (inputs, fig) = (&inputs, &fig);
            s.spawn(move || {
                let work = root().join(format!("target/fuzz-bin/worker_{w}"));
                loop {
                    if t0.elapsed() > budget || fig.lock().unwrap().findings.len() >= 20 {
                        break;
                    }
                    let Some(input) = inputs.lock().unwrap().next() else {
                        break;
                    };
                    let ti = Instant::now();
                    let r = check_binary(&input, &work);
                    let mut f = fig.lock().unwrap();
                    f.inputs += 1;
                    f.slowest = f.slowest.max(ti.elapsed());
                    match r {
                        Ok(o) => *f.outcomes.entry(format!("{o:?}")).or_default() += 1,
                        Err(why) => {
                            let p = keep(&input, 1000 + f.findings.len());
                            f.findings.push(format!("{why} (input in {})", p.display()));
                        }
                    }
                }
                let _ = std::fs::remove_dir_all(&work);
            });
        }
    });
    let mut fig = fig.into_inner().unwrap();
    for p in listing().iter().filter(|p| !before.contains(p)) {
        if !p.ends_with("target") {
            fig.findings.push(format!("created {}", p.display()));
        }
    }
    fig
}

/// CI: mutants of the shipped scenarios through the binary, as a user would run them (4 GiB,
/// SIGTERM at 5 s): 24 inputs or 15 s, whichever first, on 2 workers. No finding; at least
/// one run refused and one that ran or was interrupted.
#[test]
fn binary_inputs_within_budget() {
    let c = corpus();
    let t0 = Instant::now();
    let fig = fuzz_binary(
        stream(&c, 7, Vec::new()).skip(c.seeds.len()).take(24),
        2,
        Duration::from_secs(15),
    );
    report("fuzz through the binary (CI)", &fig, t0.elapsed());
    assert_no_findings(&fig);
    assert!(
        fig.outcomes.get("Refused").copied().unwrap_or(0) > 0,
        "{:?}",
        fig.outcomes
    );
}

/// On demand: `HYDROFRAC_FUZZ_BIN_N` inputs through the binary (default 21,000, the issue's
/// count), seed `HYDROFRAC_FUZZ_SEED`, `HYDROFRAC_FUZZ_WORKERS` at a time (default: the CPUs):
/// `HYDROFRAC_FUZZ_BIN_N=21000 cargo test --release --test fuzz_scenarios -- --ignored binary`.
#[test]
#[ignore]
fn long_binary_fuzz_run() {
    let env = |k: &str, d: u64| -> u64 {
        std::env::var(k)
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(d)
    };
    let n = env("HYDROFRAC_FUZZ_BIN_N", 21_000) as usize;
    let seed = env("HYDROFRAC_FUZZ_SEED", 1);
    let cpus = std::thread::available_parallelism().map_or(2, |n| n.get()) as u64;
    let workers = env("HYDROFRAC_FUZZ_WORKERS", cpus) as usize;
    let c = corpus();
    let reg: Vec<Input> = regressions().into_iter().map(|r| r.1).collect();
    let t0 = Instant::now();
    let fig = fuzz_binary(stream(&c, seed, reg).take(n), workers, Duration::MAX);
    report(
        &format!("fuzz through the binary (seed {seed})"),
        &fig,
        t0.elapsed(),
    );
    assert_no_findings(&fig);
}
