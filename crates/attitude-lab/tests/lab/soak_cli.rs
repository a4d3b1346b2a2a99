//! The `soak` command end to end, briefly: the lab binary starts the real service binary as its child,
//! streams for 12 s and reports one JSON object.

use crate::common::{lab_bin, service_bin_path};
use std::time::{Duration, Instant};

#[test]
fn a_short_soak_reports_every_field_and_receives_estimates() {
    let started = Instant::now();
    let output = lab_bin()
        .args([
            "soak",
            "--vehicles",
            "3",
            "--minutes",
            "0.2",
            "--filter",
            "mekf",
            "--json",
        ])
        .arg("--service-bin")
        .arg(service_bin_path())
        .output()
        .expect("the binary runs");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "soak failed: {stderr}");
    let stdout = String::from_utf8_lossy(&output.stdout);
    let line = stdout
        .lines()
        .rev()
        .find(|l| l.trim_start().starts_with('{'))
        .unwrap_or_else(|| panic!("no JSON object on stdout: {stdout}"));
    let report: serde_json::Value = serde_json::from_str(line).expect("the report is JSON");

    for field in [
        "filter",
        "vehicles",
        "rate_hz",
        "minutes",
        "window_s",
        "service_pid",
        "endpoint",
        "rss_start_kb",
        "windows",
        "sent",
        "gyro_sent",
        "estimates",
        "lost",
        "rejected",
        "rss_first_kb",
        "rss_last_kb",
        "rss_ratio",
        "p99_first_us",
        "p99_last_us",
        "p99_ratio",
        "interrupted",
        "service_exit",
        "service_exit_code",
        "service_exit_clean",
    ] {
        assert!(report.get(field).is_some(), "no `{field}` in {report}");
    }
    assert_eq!(report["filter"], "mekf");
    assert_eq!(report["vehicles"], 3);
    let windows = report["windows"].as_array().expect("windows is a list");
    assert_eq!(windows.len(), 2, "0.2 min is two windows of 6 s");
    for w in windows {
        for field in [
            "window",
            "end_s",
            "rss_kb",
            "sent",
            "estimates",
            "rejected",
            "p50_us",
            "p99_us",
            "max_us",
            "send_lag_max_ms",
        ] {
            assert!(w.get(field).is_some(), "no `{field}` in window {w}");
        }
        assert!(w["estimates"].as_u64().unwrap_or(0) > 0, "window {w}");
        assert!(w["rss_kb"].as_u64().unwrap_or(0) > 0, "window {w}");
    }
    let sent = report["sent"].as_u64().unwrap_or(0);
    let estimates = report["estimates"].as_u64().unwrap_or(0);
    // 3 vehicles × 10 Hz × 12 s.
    assert_eq!(sent, 360, "{report}");
    assert!(estimates > 0, "no estimates received: {report}");
    assert!(estimates <= sent, "{report}");
    assert_eq!(report["rejected"], 0, "{report}");
    assert_eq!(report["service_exit_clean"], true, "{report}");
    assert_eq!(report["service_exit_code"], 0, "{report}");
    assert!(
        started.elapsed() < Duration::from_secs(40),
        "took {:?}",
        started.elapsed()
    );
}
