//! The modeler's typed errors. Every message names the thing that was wrong (an object, a
//! skeleton, a file, an argument) so that a user can fix the command.

use std::path::Path;
use thiserror::Error;

#[derive(Debug, Error)]
#[non_exhaustive]
pub enum ModelError {
    #[error("{path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}: not a modeler project: {message}")]
    ProjectFormat { path: String, message: String },
    #[error("no {kind} named `{name}`{hint}")]
    NotFound {
        kind: &'static str,
        name: String,
        hint: String,
    },
    #[error("a {kind} named `{name}` already exists")]
    Duplicate { kind: &'static str, name: String },
    #[error("bad name `{name}`: {reason}")]
    BadName { name: String, reason: &'static str },
    #[error("{arg}: {message}")]
    BadArgument { arg: String, message: String },
    #[error("skeleton `{name}`: {message}")]
    Skeleton { name: String, message: String },
    #[error("object `{name}`: {message}")]
    Object { name: String, message: String },
    #[error("{0}")]
    Yari(String),
    #[error("{path}: {message}")]
    Image { path: String, message: String },
    /// A script line failed; `location` is `file:line`.
    #[error("{location}: {message}")]
    Script { location: String, message: String },
    #[error("no project at {path}; start one with `modeler new` (or `modeler import FILE.yari`)")]
    NoProject { path: String },
    #[error("{path} already exists; add --force to replace it")]
    Exists { path: String },
}

impl ModelError {
    pub fn io(path: &Path, source: std::io::Error) -> ModelError {
        ModelError::Io {
            path: path.display().to_string(),
            source,
        }
    }
    pub fn bad_arg(arg: impl Into<String>, message: impl Into<String>) -> ModelError {
        ModelError::BadArgument {
            arg: arg.into(),
            message: message.into(),
        }
    }
    pub fn skeleton(name: &str, message: impl Into<String>) -> ModelError {
        ModelError::Skeleton {
            name: name.into(),
            message: message.into(),
        }
    }
    pub fn object(name: &str, message: impl Into<String>) -> ModelError {
        ModelError::Object {
            name: name.into(),
            message: message.into(),
        }
    }
    /// A lookup failure, with the known names (or the closest ones) as a hint.
    pub fn not_found<'a>(
        kind: &'static str,
        name: &str,
        known: impl Iterator<Item = &'a str>,
    ) -> ModelError {
        let known: Vec<&str> = known.collect();
        let hint = if known.is_empty() {
            String::new()
        } else if known.len() <= 12 {
            format!(" (known: {})", known.join(", "))
        } else {
            format!(" ({} {kind}s; `modeler show` lists them)", known.len())
        };
        ModelError::NotFound {
            kind,
            name: name.into(),
            hint,
        }
    }
}

/// Checks a user-chosen name: it is written into YARI comments and typed in commands.
pub fn check_name(name: &str) -> Result<(), ModelError> {
    let bad = |reason| {
        Err(ModelError::BadName {
            name: name.into(),
            reason,
        })
    };
    if name.is_empty() {
        return bad("names must not be empty");
    }
    if name.len() > 200 {
        return bad("names are at most 200 bytes");
    }
    if !name
        .chars()
        .all(|c| c.is_alphanumeric() || "_-.+#@:".contains(c))
    {
        return bad("use letters, digits and _ - . + # @ :");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_that_would_break_a_comment_are_refused() {
        assert!(check_name("king.body_2").is_ok());
        assert!(check_name("a*/b").is_err());
        assert!(check_name("").is_err());
        assert!(check_name("two words").is_err());
    }

    #[test]
    fn not_found_lists_the_known_names() {
        let e = ModelError::not_found("object", "kng", ["king", "bat"].into_iter());
        assert_eq!(e.to_string(), "no object named `kng` (known: king, bat)");
    }
}
