//! Tidy rules: the numeric core does no I/O, no async, no JSON, no printing.

use std::path::Path;

const CORE: &[&str] = &[
    "src/ahrs",
    "src/attitude",
    "src/sensors",
    "src/filters",
    "src/sim",
    "src/bounds.rs",
    "src/rng.rs",
    "src/stats.rs",
];
const FORBIDDEN: &[&str] = &[
    "tokio",
    "zenoh",
    "serde_json",
    "std::fs",
    "std::io",
    "std::net",
    "println!",
    "eprintln!",
    "print!(",
    "dbg!(",
];

fn rust_files(path: &Path, out: &mut Vec<std::path::PathBuf>) {
    if path.is_dir() {
        for entry in std::fs::read_dir(path).unwrap() {
            rust_files(&entry.unwrap().path(), out);
        }
    } else if path.extension().is_some_and(|e| e == "rs") {
        out.push(path.to_path_buf());
    }
}

#[test]
fn numeric_core_does_no_io() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    for c in CORE {
        rust_files(&root.join(c), &mut files);
    }
    assert!(files.len() >= 8, "the core modules were found");
    let mut violations = Vec::new();
    for f in files {
        let text = std::fs::read_to_string(&f).unwrap();
        // Unit tests at the bottom of a file may print; the code above them may not.
        let code = text.split("#[cfg(test)]").next().unwrap_or("");
        for (n, line) in code.lines().enumerate() {
            let line = line.trim_start();
            if line.starts_with("//") {
                continue;
            }
            for word in FORBIDDEN {
                if line.contains(word) {
                    violations.push(format!("{}:{}: {word}", f.display(), n + 1));
                }
            }
        }
    }
    assert!(
        violations.is_empty(),
        "numeric core does I/O:\n{}",
        violations.join("\n")
    );
}

/// Layers import downwards only: the numeric core uses no study, wire, service or tool code, and the
/// service no study or tool code (a statistic both need lives in the core: `crate::stats`).
#[test]
fn layers_import_downwards() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let rules: &[(&[&str], &[&str])] = &[
        (
            CORE,
            &[
                "crate::study",
                "crate::wire",
                "crate::service",
                "crate::tools",
            ],
        ),
        (&["src/service"], &["crate::study", "crate::tools"]),
    ];
    let mut violations = Vec::new();
    for (layer, above) in rules {
        let mut files = Vec::new();
        for c in *layer {
            rust_files(&root.join(c), &mut files);
        }
        assert!(!files.is_empty(), "{layer:?} found");
        for f in files {
            let text = std::fs::read_to_string(&f).unwrap();
            for (n, line) in text.lines().enumerate() {
                if line.trim_start().starts_with("//") {
                    continue;
                }
                for module in *above {
                    if line.contains(module) {
                        violations.push(format!("{}:{}: {module}", f.display(), n + 1));
                    }
                }
            }
        }
    }
    assert!(
        violations.is_empty(),
        "imports against the layers:\n{}",
        violations.join("\n")
    );
}
