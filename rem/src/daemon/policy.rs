//! What may be spawned: the allow-list of programs (absolute paths, each optionally limited to
//! some first arguments, so that a multi-tool such as `sunray` can run only as a worker or
//! controller and not, say, write files with `sunray spd -o`), and the names of the
//! environment variables a client may give (everything else is refused; a child's
//! environment is otherwise made by remd alone, see `child`).
//!
//! A rule is written `PATH` (any arguments) or `PATH:FIRST|FIRST...` (the first argument must
//! be one of these), e.g. `/usr/local/bin/sunray:worker|controller`. An environment rule is a
//! name (`RUST_LOG`) or a prefix ending in `*` (`SUNRAY_WORKER_*`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::wire::env::PREFIX as REM_PREFIX;
use crate::wire::ids::shown;

/// Most arguments a spawn may give.
pub const MAX_ARGS: usize = 256;
/// Most environment variables a spawn may give.
pub const MAX_ENV: usize = 64;
/// Most bytes of program, arguments and environment together.
pub const MAX_COMMAND_BYTES: usize = 64 << 10;

/// The environment rules when none are configured.
pub const DEFAULT_ENV_ALLOW: [&str; 2] = ["SUNRAY_WORKER_*", "RUST_LOG"];

/// One allow-listed program.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ProgramRule {
    /// Its absolute path.
    pub path: PathBuf,
    /// The first arguments it may be given; `None` = any arguments.
    pub first_args: Option<Vec<String>>,
}

impl ProgramRule {
    /// Parses `PATH` or `PATH:FIRST|FIRST...`.
    pub fn parse(rule: &str) -> Result<Self> {
        let (path, first) = match rule.rsplit_once(':') {
            Some((p, f)) if !f.contains('/') => (p, Some(f)),
            _ => (rule, None),
        };
        let path = PathBuf::from(path);
        if !path.is_absolute() {
            return Err(Error::Config(format!(
                "--allow {rule}: {} is not an absolute path",
                path.display()
            )));
        }
        let first_args = match first {
            None => None,
            Some(f) => {
                let list: Vec<String> = f
                    .split('|')
                    .map(str::trim)
                    .filter(|a| !a.is_empty())
                    .map(str::to_string)
                    .collect();
                if list.is_empty() {
                    return Err(Error::Config(format!(
                        "--allow {rule}: no first argument after ':'"
                    )));
                }
                Some(list)
            }
        };
        Ok(ProgramRule { path, first_args })
    }
}

impl std::fmt::Display for ProgramRule {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.path.display())?;
        if let Some(a) = &self.first_args {
            write!(f, ":{}", a.join("|"))?;
        }
        Ok(())
    }
}

/// The programs and environment names a daemon accepts.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SpawnPolicy {
    /// The allow-listed programs.
    pub programs: Vec<ProgramRule>,
    /// Names (or `PREFIX*`) of variables a spawn may set.
    pub env_allow: Vec<String>,
}

impl SpawnPolicy {
    /// True when `program` is allow-listed at all (whatever its arguments).
    pub fn knows(&self, program: &Path) -> bool {
        self.programs.iter().any(|r| r.path == program)
    }

    /// Checks one spawn: the program and its first argument against the rules, sizes, and
    /// every environment name against `env_allow`. `host` names this daemon in errors.
    pub fn check(
        &self,
        host: &str,
        program: &str,
        args: &[String],
        env: &BTreeMap<String, String>,
    ) -> Result<()> {
        if !program.starts_with('/') {
            return Err(Error::Invalid(format!(
                "program {} is not an absolute path",
                shown(program)
            )));
        }
        if args.len() > MAX_ARGS || env.len() > MAX_ENV {
            return Err(Error::Invalid(format!(
                "at most {MAX_ARGS} arguments and {MAX_ENV} environment variables"
            )));
        }
        let bytes = program.len()
            + args.iter().map(|a| a.len() + 1).sum::<usize>()
            + env
                .iter()
                .map(|(k, v)| k.len() + v.len() + 2)
                .sum::<usize>();
        if bytes > MAX_COMMAND_BYTES {
            return Err(Error::Invalid(format!(
                "the command line and environment take {bytes} bytes; the limit is \
                 {MAX_COMMAND_BYTES}"
            )));
        }
        if args.iter().chain(env.values()).any(|s| s.contains('\0')) {
            return Err(Error::Invalid("an argument or value contains NUL".into()));
        }
        let rules: Vec<&ProgramRule> = self
            .programs
            .iter()
            .filter(|r| r.path.as_os_str() == program)
            .collect();
        if rules.is_empty() {
            return Err(Error::NotAllowed(program.to_string(), host.to_string()));
        }
        let first = args.first().map(String::as_str);
        let fits = |r: &&ProgramRule| {
            r.first_args
                .as_ref()
                .is_none_or(|list| first.is_some_and(|f| list.iter().any(|a| a == f)))
        };
        if !rules.iter().any(fits) {
            let allowed: Vec<String> = rules.iter().map(|r| r.to_string()).collect();
            return Err(Error::Refused(format!(
                "{program} {} is not allowed on host {host}: the allow-list says {}",
                first.unwrap_or("(no arguments)"),
                allowed.join(", ")
            )));
        }
        for name in env.keys() {
            self.check_env_name(host, name)?;
        }
        Ok(())
    }

    fn check_env_name(&self, host: &str, name: &str) -> Result<()> {
        let well_formed = !name.is_empty()
            && name.len() <= 128
            && name.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_');
        if !well_formed {
            return Err(Error::Invalid(format!(
                "bad environment variable name {}",
                shown(name)
            )));
        }
        let allowed = !name.starts_with(REM_PREFIX)
            && self
                .env_allow
                .iter()
                .any(|rule| match rule.strip_suffix('*') {
                    Some(prefix) => name.starts_with(prefix),
                    None => rule == name,
                });
        if allowed {
            Ok(())
        } else {
            Err(Error::Refused(format!(
                "environment variable {name} may not be set on host {host} (allowed: {})",
                self.env_allow.join(", ")
            )))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn policy() -> SpawnPolicy {
        SpawnPolicy {
            programs: vec![
                ProgramRule::parse("/usr/bin/sunray:worker|controller").unwrap(),
                ProgramRule::parse("/bin/echo").unwrap(),
            ],
            env_allow: DEFAULT_ENV_ALLOW.map(String::from).to_vec(),
        }
    }

    fn args(a: &[&str]) -> Vec<String> {
        a.iter().map(|s| s.to_string()).collect()
    }

    fn env(pairs: &[(&str, &str)]) -> BTreeMap<String, String> {
        pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect()
    }

    #[test]
    fn first_arguments_restrict_a_multi_tool() {
        let p = policy();
        let none = BTreeMap::new();
        assert!(p
            .check("h", "/usr/bin/sunray", &args(&["worker"]), &none)
            .is_ok());
        assert!(p
            .check("h", "/usr/bin/sunray", &args(&["controller", "-x"]), &none)
            .is_ok());
        let spd = p.check(
            "h",
            "/usr/bin/sunray",
            &args(&["spd", "-o", "/etc/x"]),
            &none,
        );
        assert_eq!(spd.unwrap_err().code(), tonic::Code::PermissionDenied);
        assert!(p.check("h", "/usr/bin/sunray", &[], &none).is_err());
        assert!(p
            .check("h", "/bin/echo", &args(&["anything"]), &none)
            .is_ok());
        let other = p.check("h", "/bin/sh", &[], &none).unwrap_err();
        assert_eq!(other.code(), tonic::Code::PermissionDenied);
        assert_eq!(
            p.check("h", "bin/echo", &[], &none).unwrap_err().code(),
            tonic::Code::InvalidArgument
        );
    }

    #[test]
    fn only_allowed_environment_names_pass() {
        let p = policy();
        let ok = env(&[("SUNRAY_WORKER_LINE_DELAY_MS", "5"), ("RUST_LOG", "debug")]);
        assert!(p.check("h", "/bin/echo", &[], &ok).is_ok());
        for bad in [
            "LD_PRELOAD",
            "LD_LIBRARY_PATH",
            "PATH",
            "REM_PROC_ID",
            "REM_SECRET",
        ] {
            let e = p.check("h", "/bin/echo", &[], &env(&[(bad, "x")]));
            assert_eq!(
                e.unwrap_err().code(),
                tonic::Code::PermissionDenied,
                "{bad}"
            );
        }
        let malformed = p.check("h", "/bin/echo", &[], &env(&[("A=B", "x")]));
        assert_eq!(malformed.unwrap_err().code(), tonic::Code::InvalidArgument);
        let nul = p.check("h", "/bin/echo", &args(&["a\0b"]), &BTreeMap::new());
        assert!(nul.is_err());
        let many = vec!["x".to_string(); MAX_ARGS + 1];
        assert!(p.check("h", "/bin/echo", &many, &BTreeMap::new()).is_err());
    }

    #[test]
    fn rules_parse_and_print() {
        let r = ProgramRule::parse("/usr/bin/sunray:worker|controller").unwrap();
        assert_eq!(r.path, PathBuf::from("/usr/bin/sunray"));
        assert_eq!(r.to_string(), "/usr/bin/sunray:worker|controller");
        assert_eq!(ProgramRule::parse("/opt/a:b/c").unwrap().first_args, None);
        assert!(ProgramRule::parse("sunray").is_err());
        assert!(ProgramRule::parse("/x:").is_err());
    }
}
