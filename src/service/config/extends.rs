//! `extends`: one configuration file built on another (`config/ros2-dds.json5` is `config/imu.json5`
//! with the ROS 2 edge on DDS), so a preset states only what it changes and never copies values.
//!
//! A file's top-level `"extends": "base.json5"` (a path relative to the file's own directory) loads that
//! file first, itself resolved the same way (chains of any length up to [`MAX_DEPTH`], no cycles), and
//! lays the file's own values over it: objects are merged key by key, at every depth; any other value
//! (a number, a string, an array) replaces the base's; `null` removes the base's value, so the option
//! takes its default again.

use serde_json::{Map, Value};
use std::path::{Path, PathBuf};

/// Longest chain of `extends` followed (a longer one is almost certainly a mistake).
pub const MAX_DEPTH: usize = 8;

/// `value` (parsed from `origin`, a file's path, or another name when there is no file) with its
/// `extends` chain resolved; `read` reads a base file (the file system, or a map in tests).
pub fn resolve(
    value: Value,
    origin: &str,
    read: &dyn Fn(&Path) -> Result<String, String>,
) -> Result<Value, String> {
    resolve_at(value, origin, read, &mut Vec::new())
}

fn resolve_at(
    mut value: Value,
    origin: &str,
    read: &dyn Fn(&Path) -> Result<String, String>,
    chain: &mut Vec<PathBuf>,
) -> Result<Value, String> {
    let Value::Object(map) = &mut value else {
        return Ok(value);
    };
    let Some(base) = map.remove("extends") else {
        return Ok(value);
    };
    let Value::String(base) = base else {
        return Err(format!(
            "`extends` must be a file name (a string), got {base}"
        ));
    };
    if chain.len() >= MAX_DEPTH {
        return Err(format!(
            "`extends` is nested more than {MAX_DEPTH} files deep ({})",
            chain_text(chain)
        ));
    }
    // Relative to the extending file's directory (the working directory when it came from no file).
    let dir = Path::new(origin)
        .parent()
        .filter(|_| Path::new(origin).is_file())
        .unwrap_or(Path::new("."));
    let path = dir.join(&base);
    let key = path.canonicalize().unwrap_or_else(|_| path.clone());
    if chain.contains(&key) {
        chain.push(key);
        return Err(format!("`extends` makes a cycle: {}", chain_text(chain)));
    }
    let text = read(&path).map_err(|e| format!("extends {base:?}: {e}"))?;
    let parsed: Value = json5::from_str(&text).map_err(|e| {
        format!(
            "extends {base:?}: {} is not valid JSON5: {e}",
            path.display()
        )
    })?;
    if !parsed.is_object() {
        return Err(format!(
            "extends {base:?}: {} is not a JSON object",
            path.display()
        ));
    }
    chain.push(key);
    let base_value = resolve_at(parsed, &path.display().to_string(), read, chain)?;
    chain.pop();
    Ok(merge(base_value, value))
}

fn chain_text(chain: &[PathBuf]) -> String {
    chain
        .iter()
        .map(|p| p.display().to_string())
        .collect::<Vec<_>>()
        .join(" -> ")
}

/// `over` laid over `base`: objects merged key by key, other values replaced, `null` removes.
pub fn merge(base: Value, over: Value) -> Value {
    match (base, over) {
        (Value::Object(mut b), Value::Object(o)) => {
            for (k, v) in o {
                if v.is_null() {
                    b.remove(&k);
                    continue;
                }
                let merged = match b.remove(&k) {
                    Some(bv) => merge(bv, v),
                    None => strip_nulls(v),
                };
                b.insert(k, merged);
            }
            Value::Object(b)
        }
        (_, over) => strip_nulls(over),
    }
}

/// A value with no base under it: its `null`s remove nothing and are dropped (the defaults stand).
fn strip_nulls(v: Value) -> Value {
    match v {
        Value::Object(m) => Value::Object(
            m.into_iter()
                .filter(|(_, v)| !v.is_null())
                .map(|(k, v)| (k, strip_nulls(v)))
                .collect::<Map<_, _>>(),
        ),
        other => other,
    }
}

/// Reads a base file from the file system.
pub fn read_file(path: &Path) -> Result<String, String> {
    std::fs::read_to_string(path).map_err(|e| format!("cannot read {}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;
    use std::collections::HashMap;

    fn files(list: &[(&str, &str)]) -> impl Fn(&Path) -> Result<String, String> {
        let m: HashMap<PathBuf, String> = list
            .iter()
            .map(|(p, t)| (Path::new(".").join(p), t.to_string()))
            .collect();
        move |p: &Path| {
            m.get(p)
                .cloned()
                .ok_or_else(|| format!("no {}", p.display()))
        }
    }

    #[test]
    fn objects_merge_other_values_replace_null_removes() {
        let read = files(&[(
            "base.json5",
            r#"{zenoh: {mode: "peer", listen: {endpoints: ["a", "b"]}},
                service: {filter: {kind: "mekf", particles: 500}, imu: {acc: {sigma_rad: 1}}}}"#,
        )]);
        let v = resolve(
            json!({"extends": "base.json5",
                   "zenoh": {"listen": {"endpoints": ["c"]}},
                   "service": {"filter": {"particles": 20, "fiducial": null}, "imu": {"acc": null},
                               "ros2": {"enabled": true, "x": null}}}),
            "<test>",
            &read,
        )
        .unwrap();
        assert_eq!(
            v,
            json!({"zenoh": {"mode": "peer", "listen": {"endpoints": ["c"]}},
                   "service": {"filter": {"kind": "mekf", "particles": 20}, "imu": {},
                               "ros2": {"enabled": true}}})
        );
    }

    #[test]
    fn chains_resolve_and_cycles_and_depth_are_refused() {
        let read = files(&[
            ("a.json5", r#"{extends: "b.json5", service: {workers: 1}}"#),
            ("b.json5", r#"{service: {workers: 2, key_prefix: "b"}}"#),
            ("c.json5", r#"{extends: "d.json5"}"#),
            ("d.json5", r#"{extends: "c.json5"}"#),
            ("e.json5", r#"{extends: 3}"#),
            ("f.json5", r#"[1]"#),
        ]);
        let v = resolve(json!({"extends": "a.json5"}), "<test>", &read).unwrap();
        assert_eq!(v, json!({"service": {"workers": 1, "key_prefix": "b"}}));
        let e = resolve(json!({"extends": "c.json5"}), "<test>", &read).unwrap_err();
        assert!(e.contains("cycle"), "{e}");
        let e = resolve(json!({"extends": "e.json5"}), "<test>", &read).unwrap_err();
        assert!(e.contains("must be a file name"), "{e}");
        let e = resolve(json!({"extends": "f.json5"}), "<test>", &read).unwrap_err();
        assert!(e.contains("not a JSON object"), "{e}");
        let e = resolve(json!({"extends": "missing.json5"}), "<test>", &read).unwrap_err();
        assert!(e.contains("missing.json5"), "{e}");
        // A chain longer than MAX_DEPTH.
        let names: Vec<(String, String)> = (0..=MAX_DEPTH)
            .map(|i| {
                (
                    format!("n{i}.json5"),
                    format!(r#"{{extends: "n{}.json5"}}"#, i + 1),
                )
            })
            .chain([(format!("n{}.json5", MAX_DEPTH + 1), "{}".to_string())])
            .collect();
        let list: Vec<(&str, &str)> = names
            .iter()
            .map(|(a, b)| (a.as_str(), b.as_str()))
            .collect();
        let e = resolve(json!({"extends": "n0.json5"}), "<test>", &files(&list)).unwrap_err();
        assert!(e.contains("nested more than"), "{e}");
    }
}
