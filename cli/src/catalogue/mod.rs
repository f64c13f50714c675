//! A catalogue of bad and extreme input (`rppm bench inputs`, and the fast part in the
//! tests): each case writes its files into a folder of its own, runs `rppm` on them with a
//! time limit, and checks the promise of the README: a render gives an image of finite
//! pixels, anything else one `rppm: error:` line and exit code 2; never a panic or a hang.

mod cases;
mod scene;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::image_io::{bad_pixels, read_exr};

/// What `rppm` must do with a case.
#[derive(Clone, Debug)]
pub enum Expect {
    /// Exit 2 with one `rppm: error:` line that holds this text.
    Error(&'static str),
    /// Exit 0 with `{dir}/out.exr` written, every pixel finite.
    Image,
}

/// One input and what must come of it.
#[derive(Clone, Debug)]
pub struct Case {
    pub name: String,
    pub group: &'static str,
    /// Files written into the case's folder (relative paths).
    pub files: Vec<(String, Vec<u8>)>,
    /// `rppm`'s arguments; `{dir}` stands for the case's folder.
    pub args: Vec<String>,
    pub expect: Expect,
    /// Too slow for the tests (a large scene or a big render): bench only.
    pub slow: bool,
}

impl Case {
    fn new(
        name: &str,
        group: &'static str,
        files: Vec<(String, Vec<u8>)>,
        args: Vec<String>,
        expect: Expect,
    ) -> Self {
        Self {
            name: name.to_string(),
            group,
            files,
            args,
            expect,
            slow: false,
        }
    }

    fn slow(mut self) -> Self {
        self.slow = true;
        self
    }
}

/// Every case, in groups.
pub fn all_cases() -> Vec<Case> {
    let mut all = cases::structure();
    all.extend(cases::numbers());
    all.extend(cases::big());
    all.extend(cases::flags());
    all
}

/// The fast cases (`all`: every case) whose name holds `filter`.
pub fn select(all: bool, filter: Option<&str>) -> Vec<Case> {
    all_cases()
        .into_iter()
        .filter(|c| all || !c.slow)
        .filter(|c| filter.is_none_or(|f| c.name.contains(f)))
        .collect()
}

/// One line per case: group, name, what must happen.
pub fn listing(cases: &[Case]) -> String {
    cases
        .iter()
        .map(|c| {
            let slow = if c.slow { " (slow)" } else { "" };
            format!("{}\t{}\t{:?}{slow}\n", c.group, c.name, c.expect)
        })
        .collect()
}

/// How a case went.
#[derive(Clone, Debug)]
pub struct Verdict {
    pub name: String,
    pub group: &'static str,
    pub passed: bool,
    pub seconds: f64,
    /// The error line, or the image's size, or what went wrong.
    pub detail: String,
}

/// Runs `case` with the `rppm` at `rppm`, in `dir` (made afresh), for at most `limit`.
pub fn run_case(rppm: &Path, case: &Case, dir: &Path, limit: Duration) -> Verdict {
    let _ = std::fs::remove_dir_all(dir);
    let written = std::fs::create_dir_all(dir).and_then(|()| {
        case.files.iter().try_for_each(|(name, bytes)| {
            let path = dir.join(name);
            if let Some(parent) = path.parent() {
                std::fs::create_dir_all(parent)?;
            }
            std::fs::write(path, bytes)
        })
    });
    let start = Instant::now();
    let outcome = written
        .map_err(|e| format!("cannot write the case: {e}"))
        .and_then(|()| run(rppm, case, dir, limit))
        .and_then(|(code, stderr)| judge(case, dir, code, &stderr));
    Verdict {
        name: case.name.clone(),
        group: case.group,
        passed: outcome.is_ok(),
        seconds: start.elapsed().as_secs_f64(),
        detail: outcome.unwrap_or_else(|e| e),
    }
}

/// Exit code (None: killed at the limit) and standard error.
fn run(
    rppm: &Path,
    case: &Case,
    dir: &Path,
    limit: Duration,
) -> Result<(Option<i32>, String), String> {
    let folder = dir.to_string_lossy();
    let stderr_path = dir.join("stderr.txt");
    let stderr = std::fs::File::create(&stderr_path).map_err(|e| e.to_string())?;
    let mut child = Command::new(rppm)
        .args(case.args.iter().map(|a| a.replace("{dir}", &folder)))
        .env("RUST_BACKTRACE", "1") // as on many developer machines: still one line
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(stderr)
        .spawn()
        .map_err(|e| format!("cannot run {}: {e}", rppm.display()))?;
    let start = Instant::now();
    let code = loop {
        if let Some(status) = child.try_wait().map_err(|e| e.to_string())? {
            break Some(status.code().unwrap_or(-1));
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    Ok((
        code,
        std::fs::read_to_string(&stderr_path).unwrap_or_default(),
    ))
}

fn judge(case: &Case, dir: &Path, code: Option<i32>, stderr: &str) -> Result<String, String> {
    let Some(code) = code else {
        return Err("no exit within the time limit (a hang)".into());
    };
    if stderr.contains("panicked") || stderr.contains("stack backtrace") {
        return Err(format!("a panic: {}", first_line(stderr, "panicked")));
    }
    let errors: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("rppm: error:"))
        .collect();
    match &case.expect {
        Expect::Error(text) => {
            if code != 2 || errors.len() != 1 {
                return Err(format!(
                    "exit {code} with {} error lines, not one and exit 2: {}",
                    errors.len(),
                    stderr.trim()
                ));
            }
            if !errors[0].contains(text) {
                return Err(format!("{:?} does not say {text:?}", errors[0]));
            }
            // Bevy's log lines may come before; nothing else may (a backtrace, a message).
            let extra = stderr.lines().find(|l| {
                !l.trim().is_empty() && !l.starts_with("rppm: error:") && !is_log_line(l)
            });
            if let Some(line) = extra {
                return Err(format!("more than the error line: {line:?}"));
            }
            Ok(errors[0].to_string())
        }
        Expect::Image => {
            if code != 0 {
                return Err(format!(
                    "exit {code}: {}",
                    errors.first().unwrap_or(&stderr.trim())
                ));
            }
            let image = read_exr(&dir.join("out.exr"))?;
            match bad_pixels(&image) {
                0 => Ok(format!(
                    "{}×{} image, all finite",
                    image.width, image.height
                )),
                n => Err(format!("{n} NaN or infinite pixels")),
            }
        }
    }
}

/// A line of Bevy's log: a timestamp (after colour codes), a level, a target.
fn is_log_line(line: &str) -> bool {
    let mut plain = String::new();
    let mut chars = line.chars();
    while let Some(c) = chars.next() {
        if c == '\x1b' {
            chars.by_ref().find(|&d| d == 'm');
        } else {
            plain.push(c);
        }
    }
    let bytes = plain.as_bytes();
    bytes.len() > 20 && bytes[4] == b'-' && bytes[10] == b'T'
}

fn first_line<'a>(text: &'a str, holding: &str) -> &'a str {
    text.lines().find(|l| l.contains(holding)).unwrap_or("")
}

/// Runs `cases` one after another in folders under `root`, calling `done` after each.
pub fn run_cases(
    rppm: &Path,
    cases: &[Case],
    root: &Path,
    limit: Duration,
    mut done: impl FnMut(&Verdict),
) -> Vec<Verdict> {
    cases
        .iter()
        .enumerate()
        .map(|(i, case)| {
            let verdict = run_case(rppm, case, &root.join(format!("{i:03}")), limit);
            done(&verdict);
            verdict
        })
        .collect()
}

/// The verdicts as a Markdown table, failures first, and a count per group.
pub fn table(verdicts: &[Verdict]) -> String {
    let mut rows: Vec<&Verdict> = verdicts.iter().collect();
    rows.sort_by_key(|v| v.passed);
    let mut out =
        String::from("| case | group | verdict | s | what happened |\n|---|---|---|---:|---|\n");
    for v in rows {
        let verdict = if v.passed { "pass" } else { "FAIL" };
        let detail = v.detail.replace('|', "/").replace('\n', " ");
        out += &format!(
            "| {} | {} | {verdict} | {:.1} | {detail} |\n",
            v.name, v.group, v.seconds
        );
    }
    let passed = verdicts.iter().filter(|v| v.passed).count();
    out += &format!("\n{passed} of {} cases pass\n", verdicts.len());
    out
}

/// The folder the catalogue's cases are written under by default.
pub fn default_root() -> PathBuf {
    std::env::temp_dir().join(format!("rppm_inputs_{}", std::process::id()))
}
