//! Script mode: the same commands, one per line, read from a file or standard input.
//!
//! Each line is split like a shell would (quotes, backslashes; see `shell-words`) and
//! parsed by the same clap parser as the command line, without `modeler` and `--project`.
//! Blank lines and lines starting with `#` are skipped; a line ending in `\` continues on
//! the next. All commands work on the project in memory; it is saved once, after the last
//! line. The first failing line stops the script with `FILE:LINE: message`, and the project
//! file stays as it was before the script. (`export` and `preview` lines write their files
//! when they run.) `--help` on a line prints the help and goes on.

use super::commands::ScriptLine;
use super::Session;
use crate::error::ModelError;
use clap::Parser;
use std::io::Read;
use std::path::Path;

/// Runs a script file (`-` reads standard input) in the session.
pub fn run_file(session: &mut Session<'_>, file: &Path) -> Result<(), ModelError> {
    let (name, text) = if file.as_os_str() == "-" {
        let mut text = String::new();
        std::io::stdin()
            .read_to_string(&mut text)
            .map_err(|e| ModelError::io(Path::new("<stdin>"), e))?;
        ("<stdin>".to_string(), text)
    } else {
        (
            file.display().to_string(),
            std::fs::read_to_string(file).map_err(|e| ModelError::io(file, e))?,
        )
    };
    run_text(session, &name, &text)
}

/// The logical lines of a script: (first line number, text), continuations joined.
pub fn logical_lines(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut pending: Option<(usize, String)> = None;
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim_end();
        let (start, mut acc) = pending.take().unwrap_or((i + 1, String::new()));
        if let Some(body) = line.strip_suffix('\\') {
            acc.push_str(body);
            acc.push(' ');
            pending = Some((start, acc));
            continue;
        }
        acc.push_str(line);
        out.push((start, acc));
    }
    if let Some(p) = pending {
        out.push(p);
    }
    out
}

/// Runs script text in the session; errors carry `name:line`.
pub fn run_text(session: &mut Session<'_>, name: &str, text: &str) -> Result<(), ModelError> {
    session.in_script = true;
    let result = run_lines(session, name, text);
    session.in_script = false;
    result
}

fn run_lines(session: &mut Session<'_>, name: &str, text: &str) -> Result<(), ModelError> {
    for (line_no, line) in logical_lines(text) {
        let trimmed = line.trim();
        if trimmed.is_empty() || trimmed.starts_with('#') {
            continue;
        }
        let location = format!("{name}:{line_no}");
        let words = shell_words::split(trimmed).map_err(|e| ModelError::Script {
            location: location.clone(),
            message: format!("cannot split the line into words: {e}"),
        })?;
        let parsed = match ScriptLine::try_parse_from(&words) {
            Ok(p) => p,
            Err(e)
                if matches!(
                    e.kind(),
                    clap::error::ErrorKind::DisplayHelp
                        | clap::error::ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
                ) =>
            {
                session.write_out(&e.render().to_string())?;
                continue;
            }
            Err(e) => {
                let message = e.render().to_string();
                let message = message.trim_end().trim_start_matches("error: ").to_string();
                return Err(ModelError::Script { location, message });
            }
        };
        session
            .execute(parsed.command)
            .map_err(|e| ModelError::Script {
                location,
                message: e.to_string(),
            })?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn continuation_lines_join_and_keep_the_first_line_number() {
        let lines = logical_lines("a\nb \\\n  c\\\nd\n\ne");
        assert_eq!(
            lines,
            [
                (1, "a".to_string()),
                (2, "b    c d".to_string()),
                (5, String::new()),
                (6, "e".to_string())
            ]
        );
    }
}
