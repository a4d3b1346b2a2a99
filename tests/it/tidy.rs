//! Tidy rules: the numeric core (the crate `attitude-core`) does no I/O, no async, no JSON, no
//! printing: its manifest has no such dependency (so the compiler refuses any), and its code no file
//! or console access. Nothing depends on the laboratory (the crate `attitude-lab`).

use crate::common::repo;
use std::path::Path;

const CORE: &[&str] = &["crates/attitude-core/src"];
/// Dependencies the core crate must never have.
const CORE_MUST_NOT_DEPEND_ON: &[&str] = &["zenoh", "tokio", "serde_json", "plotters", "json5"];
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
fn the_core_crate_depends_on_no_io_crate() {
    let root = repo();
    let manifest = std::fs::read_to_string(root.join("crates/attitude-core/Cargo.toml")).unwrap();
    let deps = manifest
        .split("[dependencies]")
        .nth(1)
        .expect("a [dependencies] table");
    for line in deps.lines().filter(|l| !l.trim_start().starts_with('#')) {
        let name = line.split('=').next().unwrap_or("").trim();
        assert!(
            !CORE_MUST_NOT_DEPEND_ON.contains(&name),
            "attitude-core depends on {name}"
        );
    }
}

/// The core serialises no state (a checkpoint is `service::persist`'s own format): serde appears only
/// behind the optional `serde` feature, on the configuration sections read from a file.
#[test]
fn the_core_serialises_no_state() {
    let root = repo();
    let manifest = std::fs::read_to_string(root.join("crates/attitude-core/Cargo.toml")).unwrap();
    let serde_line = manifest
        .lines()
        .find(|l| l.starts_with("serde "))
        .expect("serde (optional) in the core's manifest");
    assert!(serde_line.contains("optional = true"), "{serde_line}");
    let mut files = Vec::new();
    rust_files(&root.join("crates/attitude-core/src"), &mut files);
    let mut uses = Vec::new();
    for f in files {
        let text = std::fs::read_to_string(&f).unwrap();
        for (n, line) in text.lines().enumerate() {
            let line = line.trim_start();
            if line.starts_with("//") || !line.contains("serde") {
                continue;
            }
            let config_derive = line.starts_with("#[cfg_attr(feature = \"serde\"");
            // (The configuration sections: the pipeline's, the gyro, gravity and field channels' and
            // the datasheet.)
            let in_config = [
                "ahrs/config.rs",
                "sensors/gyro/channel.rs",
                "sensors/gravity/config.rs",
                "sensors/field/config.rs",
                "ahrs/sheet.rs",
            ]
            .iter()
            .any(|c| f.ends_with(c));
            if !(config_derive && in_config) {
                uses.push(format!("{}:{}: {line}", f.display(), n + 1));
            }
        }
    }
    assert!(
        uses.is_empty(),
        "serde in the core beyond the configuration:\n{}",
        uses.join("\n")
    );
}

#[test]
fn numeric_core_does_no_io() {
    let root = repo();
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

/// Every `.rs` file of the three crates, with its code above the unit tests.
fn library_code(root: &Path) -> Vec<(std::path::PathBuf, String)> {
    let mut files = Vec::new();
    rust_files(&root.join("src"), &mut files);
    rust_files(&root.join("crates/attitude-core/src"), &mut files);
    rust_files(&root.join("crates/attitude-lab/src"), &mut files);
    files
        .into_iter()
        .map(|f| {
            let text = std::fs::read_to_string(&f).unwrap();
            let code = text.split("#[cfg(test)]").next().unwrap_or("").to_string();
            (f, code)
        })
        .collect()
}

#[test]
fn anyhow_only_in_the_command_layer() {
    let root = repo();
    let allowed = [
        root.join("src/main.rs"),
        root.join("src/cli"),
        root.join("crates/attitude-lab/src/main.rs"),
        root.join("crates/attitude-lab/src/cli"),
    ];
    let violations: Vec<String> = library_code(root)
        .into_iter()
        .filter(|(f, _)| !allowed.iter().any(|a| f.starts_with(a)))
        .filter(|(_, code)| code.contains("anyhow"))
        .map(|(f, _)| f.display().to_string())
        .collect();
    assert!(
        violations.is_empty(),
        "anyhow below the command layer (errors are typed there):\n{}",
        violations.join("\n")
    );
}

#[test]
fn the_binary_runs_no_python_and_bakes_in_no_source_path() {
    let root = repo();
    let mut violations = Vec::new();
    for (f, code) in library_code(root) {
        for (n, line) in code.lines().enumerate() {
            if line.trim_start().starts_with("//") {
                continue;
            }
            for word in ["CARGO_MANIFEST_DIR", ".venv", "python"] {
                if line.contains(word) {
                    violations.push(format!("{}:{}: {word}", f.display(), n + 1));
                }
            }
        }
    }
    assert!(
        violations.is_empty(),
        "scripts call the binary, not the other way round:\n{}",
        violations.join("\n")
    );
}

/// Layers import downwards only: the numeric core uses no study, wire, service or tool code, and the
/// service no study or tool code (a statistic both need lives in the core: `crate::stats`); the wire
/// none of the service's folders; the engine neither zenoh nor the fleet, ROS 2, the queries or the
/// wiring; the fleet and ROS 2 not each other (ARCHITECTURE.md, "The folders of `src/`").
#[test]
fn layers_import_downwards() {
    let root = repo();
    let rules: &[(&[&str], &[&str])] = &[
        (
            CORE,
            // (The core crate cannot name them at all; this also catches a path in a doc test.)
            &[
                "crate::study",
                "crate::wire",
                "crate::service",
                "crate::tools",
                "attitude_service",
            ],
        ),
        (
            &[
                "src/service",
                "src/wire",
                "src/engine",
                "src/fleet",
                "src/ros2",
                "src/query",
            ],
            &["crate::study", "crate::tools", "crate::cli"],
        ),
        // The contract imports none of the service's folders.
        (
            &["src/wire"],
            &[
                "crate::engine",
                "crate::fleet",
                "crate::ros2",
                "crate::query",
                "crate::service",
            ],
        ),
        // The engine knows neither zenoh nor the features around it: they reach it through its hooks.
        (
            &["src/engine"],
            &[
                "zenoh::",
                "crate::fleet",
                "crate::ros2",
                "crate::query",
                "crate::service::ingest",
                "crate::service::outlets",
                "crate::service::session",
                "crate::service::Node",
                "crate::service::run",
            ],
        ),
        // The features know the engine, not one another nor the wiring's `Node`.
        (
            &["src/fleet", "src/ros2"],
            &[
                "crate::query",
                "crate::service::Node",
                "crate::service::node",
            ],
        ),
        (&["src/fleet"], &["crate::ros2"]),
        (&["src/ros2"], &["crate::fleet"]),
        // The laboratory is above the service and the core: neither names it.
        (&["src", "crates/attitude-core/src"], &["attitude_lab"]),
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

/// Nothing depends on the laboratory: the service's and the core's manifests name neither the crate
/// `attitude-lab` nor what only the lab needs (plotters for its figures, indicatif for its progress
/// bars, criterion for its benches), so the service binary is built and shipped without them; the lab's
/// manifest names them and depends on the service and the core.
#[test]
fn nothing_depends_on_the_lab_and_the_service_builds_without_its_crates() {
    let root = repo();
    let lab_only = ["attitude-lab", "plotters", "indicatif", "criterion"];
    for manifest in ["Cargo.toml", "crates/attitude-core/Cargo.toml"] {
        let text = std::fs::read_to_string(root.join(manifest)).unwrap();
        for line in text.lines().filter(|l| !l.trim_start().starts_with('#')) {
            let name = line.split('=').next().unwrap_or("").trim();
            assert!(!lab_only.contains(&name), "{manifest} names {name}");
        }
    }
    let lab = std::fs::read_to_string(root.join("crates/attitude-lab/Cargo.toml")).unwrap();
    let names: Vec<&str> = lab
        .lines()
        .map(|l| l.split('=').next().unwrap_or("").trim())
        .collect();
    for needed in [
        "attitude-service",
        "attitude-core",
        "plotters",
        "indicatif",
        "criterion",
    ] {
        assert!(
            names.contains(&needed),
            "crates/attitude-lab/Cargo.toml: no {needed}"
        );
    }
}

/// The persisted cases of the property tests are replayed only from where proptest reads them: with
/// `tests/it/main.rs` beside the modules, `tests/proptest-regressions/<module>.txt` (its default,
/// `SourceParallel`). A file anywhere else under `tests/` would silently replay nothing.
#[test]
fn persisted_property_cases_are_where_proptest_reads_them() {
    let tests = repo().join("tests");
    let persisted = tests.join("proptest-regressions");
    let mut files = Vec::new();
    let mut stray = Vec::new();
    let mut walk = vec![tests.clone()];
    while let Some(dir) = walk.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk.push(path);
            } else if path.starts_with(&persisted) {
                files.push(path);
            } else if path.to_string_lossy().contains("proptest-regressions") {
                stray.push(path.display().to_string());
            }
        }
    }
    assert!(
        stray.is_empty(),
        "persisted proptest cases proptest does not read: {stray:?}"
    );
    assert!(
        !files.is_empty(),
        "{} holds the persisted cases",
        persisted.display()
    );
    for f in files {
        let module = tests
            .join("it")
            .join(f.file_stem().unwrap())
            .with_extension("rs");
        let source = std::fs::read_to_string(&module)
            .unwrap_or_else(|e| panic!("{}: no module {} ({e})", f.display(), module.display()));
        assert!(
            f.extension().is_some_and(|e| e == "txt") && source.contains("proptest!"),
            "{}: not the persisted cases of the property tests of {}",
            f.display(),
            module.display()
        );
    }
}
