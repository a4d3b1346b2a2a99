//! The two binaries split the commands: the service's are what an operator runs, the lab's the rest,
//! and neither offers the other's.

use crate::common::{lab_bin, service_bin_path};
use std::process::Command;

const SERVICE: &[&str] = &["serve", "simulate", "demo"];
const LAB: &[&str] = &[
    "montecarlo",
    "sweep",
    "scenarios",
    "quadrature",
    "bench",
    "imu-bench",
    "imu-study",
    "loadgen",
    "soak",
];

/// The subcommands `--help` lists (the lines of its "Commands:" section, `help` left out).
fn commands(mut binary: Command) -> Vec<String> {
    let out = binary.arg("--help").output().expect("the binary runs");
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    text.split("Commands:")
        .nth(1)
        .expect("a Commands: section")
        .lines()
        .skip(1)
        .take_while(|l| !l.trim().is_empty())
        // A command's line is indented by two; a description's continuation, further.
        .filter(|l| l.starts_with("  ") && !l.starts_with("   "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|c| *c != "help")
        .map(str::to_string)
        .collect()
}

#[test]
fn the_service_binary_keeps_the_operator_commands_and_the_lab_the_rest() {
    let service = commands(Command::new(service_bin_path()));
    assert_eq!(service, SERVICE, "attitude-service --help");
    let lab = commands(lab_bin());
    assert_eq!(lab, LAB, "attitude-lab --help");
    // A lab command given to the service binary is refused, and the other way round.
    for (mut binary, command) in [
        (Command::new(service_bin_path()), "montecarlo"),
        (lab_bin(), "serve"),
    ] {
        let out = binary.arg(command).output().unwrap();
        assert!(!out.status.success(), "{command} accepted");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.contains("unrecognized subcommand"), "{stderr}");
    }
}
