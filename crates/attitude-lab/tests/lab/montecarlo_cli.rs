//! The `montecarlo` command end to end: the real binary, real files.

use crate::common::{assert_nees_with_power, lab_bin, scratch_dir, CHI2_120};
use attitude_lab::study::FilterSummary;
use std::path::Path;

fn run(args: &[&str], out: &Path) -> Vec<FilterSummary> {
    let output = lab_bin()
        .arg("montecarlo")
        .args(args)
        .arg("--out")
        .arg(out)
        .output()
        .expect("the binary runs");
    assert!(
        output.status.success(),
        "montecarlo failed: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    let text = std::fs::read_to_string(out.join("summary.json")).expect("summary.json written");
    serde_json::from_str(&text).expect("summary.json is a list of filter summaries")
}

/// `[lo, hi]`, the 0.999 interval of the mean attitude NEES of `runs` runs for a consistent filter, one
/// sample per run: `χ²₃ₙ(0.0005, 0.9995)/n` (the runner's ANEES averages every epoch of the steady window
/// as well, which only narrows its spread: the epochs of a run are correlated, so the per-run interval is
/// the honest one). Values from scipy.stats.chi2.ppf.
fn anees_bounds(runs: usize) -> (f64, f64) {
    let (lo, hi) = match runs {
        20 => (30.340, 102.695),
        40 => CHI2_120,
        _ => panic!("no χ² quantiles for {runs} runs"),
    };
    (lo / runs as f64, hi / runs as f64)
}

/// `[lo, hi]`, the 0.999 interval of `√(χ²ₖ/k)`: the spread of an RMS over `k` independent samples
/// relative to its expectation (scipy.stats.chi2.ppf).
fn rms_bounds(k: usize) -> (f64, f64) {
    let (lo, hi) = match k {
        100 => (0.773923, 1.237606),
        160 => (0.820050, 1.187120),
        200 => (0.838631, 1.167096),
        1200 => (0.933327, 1.067622),
        2400 => (0.952750, 1.047725),
        _ => panic!("no χ² quantiles for k = {k}"),
    };
    (lo, hi)
}

/// The ANEES of `s` inside its bound, and the same runs with the covariance scaled by 1/2.25 or 2.25
/// (σ 1.5× too small or too large: the ANEES scales exactly by 2.25 or 1/2.25) outside it.
fn assert_anees(what: &str, anees: f64, runs: usize) {
    assert_nees_with_power(&format!("{what}: ANEES"), anees, anees_bounds(runs));
}

/// Each axis' RMS/PCRB inside `centre · rms_bounds(k)`, and an RMS 1.5× larger or smaller outside.
fn assert_rms(what: &str, ratios: [f64; 3], centre: [f64; 3], k: [usize; 3]) {
    for axis in 0..3 {
        let (lo, hi) = rms_bounds(k[axis]);
        let (lo, hi) = (lo * centre[axis], hi * centre[axis]);
        let r = ratios[axis];
        assert!(
            (lo..=hi).contains(&r),
            "{what} axis {axis}: RMS/PCRB {r} outside [{lo}, {hi}]"
        );
        for scale in [1.5, 1.0 / 1.5] {
            assert!(
                !(lo..=hi).contains(&(r * scale)),
                "{what} axis {axis}: an RMS {scale}× as large ({}) would pass [{lo}, {hi}]",
                r * scale
            );
        }
    }
}

/// 40 runs of the star-tracker scenario (seed 1): every run converges, the RMS error reaches the PCRB
/// and the covariance is honest.
///
/// * RMS/PCRB per axis: for an efficient filter the steady-window mean square over the PCRB's is a mean
///   of squared standard normals, but correlated in time: measured over 100 runs (seed 1) the per-run
///   figures spread as `χ²ₙ/n` with `n` ≈ 80 effectively independent samples per run on x and y and
///   ≈ 6 on z (the boresight, weakly observed, slowly varying). With `n` = 60 and 5 (rounded down),
///   the RMS of 40 runs lies within `√(χ²ₖ/k)` of the bound at 0.999, `k` = 2400 and 200:
///   [0.953, 1.048] on x, y and [0.839, 1.167] on z. An RMS 1.5× larger or smaller fails (checked).
/// * ANEES: `χ²₁₂₀(0.0005, 0.9995)/40 = [1.887, 4.440]` (one sample per run, see `anees_bounds`); a
///   covariance 1.5× too small or too large in σ fails (checked).
///
/// Measured: RMS/PCRB 0.990, 1.013, 0.989; ANEES 2.986 (× 2.25: 6.72, ÷ 2.25: 1.327).
#[test]
fn star_tracker_mekf_reaches_the_bound_with_honest_covariance() {
    let out = scratch_dir("star-tracker");
    let summary = run(
        &[
            "--scenario",
            "star-tracker",
            "--filters",
            "mekf",
            "--runs",
            "40",
            "--seed",
            "1",
        ],
        &out,
    );
    assert_eq!(summary.len(), 1);
    let s = &summary[0];
    assert_eq!(
        (s.filter.as_str(), s.kind.as_str(), s.fiducial.as_deref()),
        ("mekf", "mekf", None)
    );
    assert_eq!(s.runs, 40);
    assert_eq!(s.converged_runs, 40, "{s:?}");
    eprintln!(
        "star-tracker mekf: RMS/PCRB {:?}, ANEES {}",
        s.rms_over_pcrb, s.anees
    );
    // Above the bound's lower edge too: an RMS far below the PCRB would mean the bound or the error is
    // wrong.
    assert_rms(
        "star-tracker mekf",
        s.rms_over_pcrb,
        [1.0; 3],
        [40 * 60, 40 * 60, 40 * 5],
    );
    for axis in 0..3 {
        // The steady state of a 6″ star camera with ~8 stars is well under an arcsecond on x/y.
        assert!(
            s.pcrb_deg[axis] * 3600.0 < 3.0,
            "PCRB {} arcsec",
            s.pcrb_deg[axis] * 3600.0
        );
    }
    assert_anees("star-tracker mekf", s.anees, s.runs);
    assert!(s.us_per_step > 0.0);
    for f in [
        "summary.md",
        "study.json",
        "errors_mekf.png",
        "error_angle_mekf.png",
        "rms_vs_pcrb.png",
    ] {
        let len = std::fs::metadata(out.join(f)).map(|m| m.len()).unwrap_or(0);
        assert!(len > 1000, "{f} missing or empty");
    }
    let md = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(md.contains("`mekf`"));
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn same_seed_same_summary_whatever_the_thread_count() {
    let strip = |mut v: Vec<FilterSummary>| {
        for s in &mut v {
            s.us_per_step = 0.0; // wall time is the only thing allowed to differ
        }
        v
    };
    let args = [
        "--scenario",
        "magnetometer-leo",
        "--filters",
        "mekf",
        "--runs",
        "4",
        "--seed",
        "42",
        "--duration",
        "3600",
    ];
    let (a_dir, b_dir, c_dir) = (
        scratch_dir("det-a"),
        scratch_dir("det-b"),
        scratch_dir("det-c"),
    );
    let a = strip(run(&[&args[..], &["--jobs", "1"]].concat(), &a_dir));
    let b = strip(run(&[&args[..], &["--jobs", "2"]].concat(), &b_dir));
    assert_eq!(a, b);
    let mut other = args;
    other[7] = "43";
    let c = strip(run(&other, &c_dir));
    assert_ne!(a, c, "a different seed gives different data");
    for d in [a_dir, b_dir, c_dir] {
        let _ = std::fs::remove_dir_all(d);
    }
}

#[test]
fn bad_arguments_are_refused_with_a_reason() {
    for (args, expected) in [
        (vec!["--scenario", "mars-orbit"], "mars-orbit"),
        (
            vec!["--scenario", "star-tracker", "--filters", "ekf"],
            "ekf",
        ),
        (vec!["--scenario", "star-tracker", "--runs", "0"], "--runs"),
        (
            vec!["--scenario", "star-tracker", "--duration=-5"],
            "duration",
        ),
        (
            vec![
                "--scenario",
                "star-tracker",
                "--filters",
                "sghqf",
                "--level",
                "5",
            ],
            "--level",
        ),
    ] {
        let out = scratch_dir("bad");
        let output = lab_bin()
            .arg("montecarlo")
            .args(&args)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        assert!(!output.status.success(), "{args:?} accepted");
        let err = String::from_utf8_lossy(&output.stderr);
        assert!(err.contains(expected), "{args:?}: {err}");
    }
}

#[test]
fn scenarios_command_documents_every_scenario() {
    let output = lab_bin().arg("scenarios").output().unwrap();
    assert!(output.status.success());
    let text = String::from_utf8_lossy(&output.stdout);
    for name in ["star-tracker", "magnetometer-leo", "lost-in-space"] {
        assert!(text.contains(name), "{name} missing");
    }
}

#[test]
fn particle_filter_studies_are_deterministic_too() {
    let strip = |mut v: Vec<FilterSummary>| {
        for s in &mut v {
            s.us_per_step = 0.0;
        }
        v
    };
    let args = [
        "--scenario",
        "lost-in-space",
        "--filters",
        "qpf:average,qpf:propagated,usque:average",
        "--runs",
        "3",
        "--seed",
        "7",
        "--duration",
        "120",
        "--particles",
        "300",
    ];
    let (a_dir, b_dir) = (scratch_dir("qpf-det-a"), scratch_dir("qpf-det-b"));
    let a = strip(run(&[&args[..], &["--jobs", "1"]].concat(), &a_dir));
    let b = strip(run(&[&args[..], &["--jobs", "2"]].concat(), &b_dir));
    assert_eq!(a, b);
    let labels: Vec<&str> = a.iter().map(|s| s.filter.as_str()).collect();
    assert_eq!(labels, ["qpf:average", "qpf:propagated", "usque:average"]);
    assert_eq!(a[0].particles, Some(300));
    assert_eq!(a[0].fiducial.as_deref(), Some("average"));
    assert_eq!(a[1].fiducial.as_deref(), Some("propagated"));
    assert_eq!(a[2].particles, None);
    // The particle filter recovers from a uniformly random attitude in this scenario.
    assert_eq!(a[0].converged_runs, 3, "{:?}", a[0]);
    for d in [a_dir, b_dir] {
        let _ = std::fs::remove_dir_all(d);
    }
}

/// The SGHQF in a study: its level on its rows only (`--level`), and both fiducials the same to
/// rounding in this short run (the symmetry argument of docs/algorithms.md §3).
#[test]
fn sghqf_rows_carry_their_level() {
    let args = [
        "--scenario",
        "star-tracker",
        "--filters",
        "sghqf:propagated,sghqf:average,usque:average",
        "--level",
        "2",
        "--runs",
        "2",
        "--duration",
        "120",
        "--jobs",
        "1",
    ];
    let out = scratch_dir("sghqf-study");
    let rows = run(&args, &out);
    let labels: Vec<(&str, Option<u8>)> =
        rows.iter().map(|s| (s.filter.as_str(), s.level)).collect();
    assert_eq!(
        labels,
        [
            ("sghqf:propagated", Some(2)),
            ("sghqf:average", Some(2)),
            ("usque:average", None)
        ]
    );
    assert_eq!(rows[0].kind, "sghqf");
    for (p, a) in rows[0].steady_rms_deg.iter().zip(rows[1].steady_rms_deg) {
        assert!((p - a).abs() < 1e-6 * p, "{p} vs {a}");
    }
    let md = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(md.contains("| `sghqf:average` | L = 2 |"), "{md}");
    let _ = std::fs::remove_dir_all(out);
}

#[test]
fn sweep_reports_one_row_per_particle_count() {
    let out = scratch_dir("sweep");
    let output = lab_bin()
        .args([
            "sweep",
            "--scenario",
            "lost-in-space",
            "--particles",
            "100,200",
            "--runs",
            "2",
            "--duration",
            "60",
        ])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let rows: Vec<FilterSummary> =
        serde_json::from_str(&std::fs::read_to_string(out.join("sweep.json")).unwrap()).unwrap();
    let counts: Vec<Option<usize>> = rows.iter().map(|r| r.particles).collect();
    assert_eq!(counts, [Some(100), Some(200)]);
    assert!(rows
        .iter()
        .all(|r| r.filter == "qpf:average" && r.runs == 2));
    assert!(std::fs::metadata(out.join("sweep.png")).unwrap().len() > 10_000);
    assert!(std::fs::read_to_string(out.join("sweep.md"))
        .unwrap()
        .contains("| 200 |"));
    let _ = std::fs::remove_dir_all(&out);
}

/// The targets of the particle filter with the averaged fiducial (seeded), with bounds from the spread
/// of the figures (see `star_tracker_mekf_reaches_the_bound_with_honest_covariance`):
///
/// * magnetometer-leo from 50°/50°/160°, 40 runs (seed 11): at least 39 converge (measured: 40, and 60
///   of 60 runs; the MEKF baseline, 8 of 40, converges less often); RMS/PCRB per axis within
///   `√(χ²₁₆₀/160)` of 1 at 0.999, [0.820, 1.187] (per-run spread measured over 60 runs: ≈ 5.5, 4.8,
///   4.3 effectively independent samples per run, taken as 4); ANEES in `χ²₁₂₀/40` = [1.887, 4.440].
///   Measured: RMS/PCRB 0.951, 1.001, 1.034; ANEES 2.873.
/// * star-tracker, 20 runs (seed 11, 1000 particles): every run converges; RMS/PCRB within `√(χ²ₖ/k)` of
///   its centre at 0.999, `k` = 20·60 on x, y ([0.933, 1.068] about 1) and 20·5 on z about 1.117: the
///   particle filter is measurably above the bound on the boresight (docs/accuracy.md: about 9% at
///   1000 particles; over 60 runs, seed 11: 1.009, 1.004, 1.117 with per-run spreads of 84, 81 and
///   7.8 samples), so z's bound is [0.864, 1.382];
///   ANEES in `χ²₆₀/20` = [1.517, 5.135] (at 20 runs its power against a covariance 1.5× off is 0.91
///   and 0.78 for one sample per run, more for the window average; on this data both fail, checked).
///   Measured: RMS/PCRB 1.017, 1.002, 1.163; ANEES 3.001.
///
/// Each bound is shown to reject the same runs with an RMS 1.5× larger or smaller and a covariance
/// 1.5× too small or too large in σ.
#[test]
fn qpf_average_converges_from_large_errors_and_reaches_the_bound() {
    let out = scratch_dir("qpf-mag");
    let mag = run(
        &[
            "--scenario",
            "magnetometer-leo",
            "--filters",
            "qpf:average,mekf",
            "--runs",
            "40",
            "--seed",
            "11",
        ],
        &out,
    );
    let (qpf, mekf) = (&mag[0], &mag[1]);
    eprintln!(
        "magnetometer-leo qpf:average: converged {}/{}, RMS/PCRB {:?}, ANEES {}; mekf converged {}",
        qpf.converged_runs, qpf.runs, qpf.rms_over_pcrb, qpf.anees, mekf.converged_runs
    );
    assert!(
        qpf.converged_runs >= 39,
        "≥ 39 of 40 converge from 50°/50°/160°: {qpf:?}"
    );
    assert_rms(
        "magnetometer-leo qpf:average",
        qpf.rms_over_pcrb,
        [1.0; 3],
        [160; 3],
    );
    assert_anees("magnetometer-leo qpf:average", qpf.anees, qpf.runs);
    assert!(
        mekf.converged_runs < qpf.converged_runs,
        "the MEKF baseline is worse here: {mekf:?}"
    );
    let out2 = scratch_dir("qpf-st");
    let st = run(
        &[
            "--scenario",
            "star-tracker",
            "--filters",
            "qpf:average",
            "--runs",
            "20",
            "--seed",
            "11",
            "--particles",
            "1000",
        ],
        &out2,
    );
    let s = &st[0];
    eprintln!(
        "star-tracker qpf:average: RMS/PCRB {:?}, ANEES {}",
        s.rms_over_pcrb, s.anees
    );
    assert_eq!(s.converged_runs, 20, "{s:?}");
    assert_rms(
        "star-tracker qpf:average",
        s.rms_over_pcrb,
        [1.0, 1.0, 1.117],
        [20 * 60, 20 * 60, 20 * 5],
    );
    assert_anees("star-tracker qpf:average", s.anees, s.runs);
    for d in [out, out2] {
        let _ = std::fs::remove_dir_all(d);
    }
}

#[test]
fn bench_reports_every_filter_as_json() {
    let output = lab_bin()
        .args(["bench", "--json", "--seconds", "0.05", "--particles", "200"])
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    for key in [
        "qpf_ns_per_particle_step",
        "qpf_us_per_step",
        "usque_us_per_step",
        "mekf_us_per_step",
    ] {
        let x = v[key].as_f64().unwrap_or(f64::NAN);
        assert!(x.is_finite() && x > 0.0, "{key}: {v}");
    }
    assert_eq!(v["particles"], 200);
    // Speed belongs to the benchmarks (BENCHMARKS.md): here only that the derived figures are what
    // they say (the rates are printed to 1e-3 µs).
    let f = |key: &str| v[key].as_f64().unwrap();
    for (ratio, num) in [
        ("qpf_over_mekf", "qpf_us_per_step"),
        ("usque_over_mekf", "usque_us_per_step"),
    ] {
        let want = f(num) / f("mekf_us_per_step");
        assert!(
            (f(ratio) / want - 1.0).abs() < 1e-3,
            "{ratio} {} vs {num}/mekf_us_per_step {want}",
            f(ratio)
        );
    }
    let per_particle = f("qpf_us_per_step") * 1e3 / 200.0;
    assert!(
        (f("qpf_ns_per_particle_step") / per_particle - 1.0).abs() < 1e-3,
        "{v}"
    );
}
