//! Docs that cannot drift: every repository path named in `README.md`, `docs/*.md` and the
//! crate's doc comments exists (a renamed or removed file is renamed in its docs too).

use std::path::{Path, PathBuf};

/// The folders of the repository whose paths the docs name.
const ROOTS: [&str; 11] = [
    "src/",
    "scripts/",
    "fixtures/",
    "docs/",
    "tests/",
    "deploy/",
    ".ci/",
    "benches/",
    "examples/",
    "python/",
    "web/",
];

/// The repository paths in `line`: a root folder, then path characters, not preceded by a
/// character that would make it part of a longer path or word.
fn paths_in(line: &str) -> Vec<String> {
    let bytes = line.as_bytes();
    let mut found = Vec::new();
    for root in ROOTS {
        let mut from = 0;
        while let Some(at) = line[from..].find(root).map(|i| i + from) {
            from = at + root.len();
            let before_ok = at == 0 || {
                let b = bytes[at - 1];
                !(b.is_ascii_alphanumeric() || b == b'_' || b == b'/' || b == b'.' || b == b'-')
            };
            if !before_ok {
                continue;
            }
            let end = line[at..]
                .find(|c: char| !(c.is_ascii_alphanumeric() || "_./-".contains(c)))
                .map_or(line.len(), |i| at + i);
            let path = line[at..end].trim_end_matches(['.', '-', '/']);
            // Wildcards and brace lists name families of files, not one path.
            let rest = &line[end..];
            if path.len() > root.len() && !rest.starts_with('*') && !rest.starts_with('{') {
                found.push(path.to_string());
            }
        }
    }
    found
}

fn docs_files(root: &Path) -> Vec<PathBuf> {
    let mut files = vec![root.join("README.md")];
    let mut stack = vec![root.join("docs"), root.join("src")];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let p = entry.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|e| e == "md" || e == "rs") {
                files.push(p);
            }
        }
    }
    files.sort();
    files
}

#[test]
fn every_path_the_docs_name_exists() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut missing = Vec::new();
    let mut checked = 0;
    for file in docs_files(root) {
        let text = std::fs::read_to_string(&file).unwrap();
        let is_rust = file.extension().is_some_and(|e| e == "rs");
        for (i, line) in text.lines().enumerate() {
            let trimmed = line.trim_start();
            if is_rust && !(trimmed.starts_with("//!") || trimmed.starts_with("///")) {
                continue;
            }
            for path in paths_in(line) {
                checked += 1;
                if !root.join(&path).exists() {
                    let shown = file.strip_prefix(root).unwrap_or(&file).display();
                    missing.push(format!("{shown}:{}: {path}", i + 1));
                }
            }
        }
    }
    assert!(
        checked > 100,
        "only {checked} paths found: the scan is broken"
    );
    assert!(
        missing.is_empty(),
        "paths named in docs that do not exist:\n{}",
        missing.join("\n")
    );
}

#[test]
fn paths_are_found_as_written() {
    assert_eq!(
        paths_in("see `src/earth/polygon/validity.rs`, and scripts/x.sh."),
        ["src/earth/polygon/validity.rs", "scripts/x.sh"]
    );
    assert!(paths_in("target/same-output/old/ and mysrc/x.rs").is_empty());
    assert!(paths_in("fixtures/*.geojson").is_empty());
}
