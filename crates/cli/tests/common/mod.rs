//! Helpers shared by the end-to-end tests of the `clothcast` binary.
#![allow(dead_code)] // each test file uses its own subset

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The binary under test.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_clothcast"))
}

/// Run the binary with `args`.
pub fn run(args: &[&str]) -> Output {
    bin().args(args).output().expect("binary runs")
}

/// Standard output and error together.
pub fn text(o: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

/// The exit code.
pub fn code(o: &Output) -> i32 {
    o.status.code().expect("exited normally, not by a signal")
}

/// Assert that the binary exited with `code` (printing its output if not); returns its output.
pub fn expect_exit(o: &Output, code: i32) -> String {
    let t = text(o);
    assert_eq!(o.status.code(), Some(code), "{t}");
    t
}

/// Assert that `text` (a run's output) contains `needle`, printing it if not.
pub fn assert_mentions(text: &str, needle: &str) {
    assert!(text.contains(needle), "expected {needle:?} in\n{text}");
}

/// Run `clothcast STAGE -q [-c CFG] EXTRA... -o OUT` (a pipeline command writing into `out`).
pub fn run_stage(stage: &str, out: &Path, cfg: Option<&Path>, extra: &[&str]) -> Output {
    let mut args = vec![stage, "-q"];
    if let Some(cfg) = cfg {
        args.extend(["-c", cfg.to_str().unwrap()]);
    }
    args.extend_from_slice(extra);
    args.extend(["-o", out.to_str().unwrap()]);
    run(&args)
}

/// A test mesh under `data/meshes/`.
pub fn data(rel: &str) -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/meshes")).join(rel)
}

/// A test's own directory, removed when the test ends, unless it ends by a panic (a failing
/// test keeps its outputs to look at). A whole suite left some 115 MB behind per run before.
pub struct TmpDir(PathBuf);

impl std::ops::Deref for TmpDir {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl Drop for TmpDir {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// A fresh, empty directory for one test (named after the test file, the process and `name`).
pub fn tmpdir(name: &str) -> TmpDir {
    let d = std::env::temp_dir().join(format!("clothcast-{}-{}-{name}", env!("CARGO_CRATE_NAME"), std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    TmpDir(d)
}

/// Write the scenario file `dir/name` (overwriting it); returns its path.
pub fn write_config(dir: &Path, name: &str, toml: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, toml).unwrap();
    path
}

/// Write `toml` as `out/c.toml` and run `clothcast STAGE -q -c out/c.toml EXTRA... -o out`,
/// asserting exit `code`; returns its output.
pub fn run_configured(stage: &str, out: &Path, toml: &str, extra: &[&str], code: i32) -> String {
    let cfg = write_config(out, "c.toml", toml);
    expect_exit(&run_stage(stage, out, Some(&cfg), extra), code)
}

/// `summary.json` of an output directory.
pub fn summary(dir: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(dir.join("summary.json")).unwrap()).unwrap()
}

/// Assert that every one of `keys` is present and not null in `v` (the summary's section `what`).
pub fn assert_keys(v: &Value, what: &str, keys: &[&str]) {
    for k in keys {
        assert!(!v[k].is_null(), "{what}.{k} missing");
    }
}

/// Run `clothcast STAGE --seed SEED` twice, into two fresh directories, and assert that `files`
/// come out byte for byte the same; returns the two directories (for further comparisons).
pub fn assert_reproducible(stage: &str, seed: &str, files: &[&str]) -> (TmpDir, TmpDir) {
    let (a, b) = (tmpdir(&format!("{stage}-seed-a")), tmpdir(&format!("{stage}-seed-b")));
    for d in [&a, &b] {
        expect_exit(&run_stage(stage, d, None, &["--seed", seed]), 0);
    }
    for f in files {
        assert_eq!(std::fs::read(a.join(f)).unwrap(), std::fs::read(b.join(f)).unwrap(), "{f} differs");
    }
    (a, b)
}
