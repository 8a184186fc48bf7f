//! Running a built binary from a test: its exit status, standard output
//! and standard error, the output as text.
//!
//! The path of the binary is an argument because only the package that
//! builds it knows it (`env!("CARGO_BIN_EXE_<name>")` exists only in that
//! package's own tests and benches).

use std::ffi::OsStr;
use std::path::Path;
use std::process::{Command, ExitStatus};

/// What a finished run left: its status and its output (invalid UTF-8
/// replaced, as `String::from_utf8_lossy` does).
#[derive(Clone, Debug)]
pub struct Output {
    /// The command line, for messages.
    pub command: String,
    pub status: ExitStatus,
    pub stdout: String,
    pub stderr: String,
}

impl Output {
    /// Whether the run exited with status 0.
    pub fn success(&self) -> bool {
        self.status.success()
    }

    /// `(success, stdout, stderr)`, the shape tests destructure.
    pub fn into_parts(self) -> (bool, String, String) {
        (self.status.success(), self.stdout, self.stderr)
    }

    /// The output, after panicking unless the run succeeded; the panic
    /// names the command line and its status and shows its standard error.
    #[track_caller]
    pub fn assert_success(self) -> Self {
        assert!(
            self.status.success(),
            "`{}` failed ({}); its standard error:\n{}",
            self.command,
            self.status,
            self.stderr
        );
        self
    }
}

/// Runs `bin` with `args` to the end and collects what it wrote. Panics
/// only if it cannot be started; a failing run is an [`Output`] to check.
#[track_caller]
pub fn run(bin: &str, args: &[&str]) -> Output {
    output(Command::new(bin).args(args))
}

/// [`run`], then [`Output::assert_success`].
#[track_caller]
pub fn run_ok(bin: &str, args: &[&str]) -> Output {
    run(bin, args).assert_success()
}

/// Runs a prepared command (environment, working directory, a wrapper
/// such as `timeout`) to the end and collects what it wrote. Panics only if
/// it cannot be started.
#[track_caller]
pub fn output(cmd: &mut Command) -> Output {
    let command = command_line(cmd);
    let out = cmd
        .output()
        .unwrap_or_else(|e| panic!("cannot run `{command}`: {e}"));
    Output {
        command,
        status: out.status,
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

/// A path as an argument. Panics if it is not UTF-8 (test paths are).
#[track_caller]
pub fn arg(p: &Path) -> &str {
    p.to_str()
        .unwrap_or_else(|| panic!("{} is not UTF-8", p.display()))
}

/// The program and its arguments, space-separated, for messages.
fn command_line(cmd: &Command) -> String {
    std::iter::once(cmd.get_program())
        .chain(cmd.get_args())
        .map(OsStr::to_string_lossy)
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn output_and_status_are_collected() {
        let out = run("sh", &["-c", "echo out; echo err >&2; exit 3"]);
        assert!(!out.success());
        assert_eq!(out.status.code(), Some(3));
        assert_eq!(
            (out.stdout.as_str(), out.stderr.as_str()),
            ("out\n", "err\n")
        );
        assert_eq!(out.command, "sh -c echo out; echo err >&2; exit 3");
        assert!(run_ok("true", &[]).success());
    }

    #[test]
    #[should_panic(
        expected = "`sh -c echo why >&2; exit 1` failed (exit status: 1); its standard error:\nwhy"
    )]
    fn a_failed_run_says_what_ran_and_why() {
        run_ok("sh", &["-c", "echo why >&2; exit 1"]);
    }

    #[test]
    #[should_panic(expected = "cannot run `/nonexistent/binary`")]
    fn a_missing_binary_is_named() {
        run("/nonexistent/binary", &[]);
    }
}
