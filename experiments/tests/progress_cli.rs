//! Progress bars: shown with an ETA when stderr is a terminal, hidden with
//! `--quiet` and when stderr is not a terminal (tests, CI, pipes).

mod common;

use std::path::Path;
use std::process::Command;

use common::Sandbox;

/// Run `smokelab <args>` on a pseudo-terminal (util-linux `script`) in
/// `cwd` and return everything it drew there.
fn on_terminal(args: &str, cwd: &Path) -> String {
    let command = format!("{} {args}", env!("CARGO_BIN_EXE_smokelab"));
    let o = Command::new("script")
        .args(["-qec", &command, "/dev/null"])
        .current_dir(cwd)
        .output()
        .expect("run util-linux `script` for a pseudo-terminal");
    let screen = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(o.status.success(), "{args}: {screen}");
    screen
}

#[test]
fn render_and_noise_show_a_bar_with_eta_only_on_a_terminal_without_quiet() {
    let sb = Sandbox::new();
    let d = sb.path();
    sb.small_hot_cold_run("r", &["--save-every", "4"]);
    for (unit, args) in [
        (
            "density samples",
            "render r --image 64x64 --march-step 0.05",
        ),
        ("samples", "noise curl --res 48"),
    ] {
        let kind = args.split(' ').next().unwrap();
        let command = |out: &str, extra: &str| format!("{args} --out {kind}-{out} {extra}");
        let shown = on_terminal(&command("tty", ""), d);
        assert!(
            shown.contains(&format!("{unit}, ETA")),
            "{args}: no bar on a terminal: {shown}"
        );
        let quiet = on_terminal(&command("quiet", "--quiet"), d);
        assert!(!quiet.contains("ETA"), "{args} --quiet drew: {quiet}");
        let piped = command("piped", "");
        let o = sb.ok(&piped.split_whitespace().collect::<Vec<_>>());
        assert!(
            o.stderr.is_empty(),
            "{piped}: stderr is not a terminal, yet it got {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
}
