//! Named colours: `color = UNC_Blue` instead of `color = 0.078,0.361,0.753` (thesis §2.3).
//!
//! [`ColourTable::builtin`] ships the usual names; a user file extends or overrides them at
//! run time ([`ColourTable::load_file`], or [`ColourTable::for_run`] with a `--colors FILE`
//! flag or the `YARI_COLORS` environment variable). The file has one `name r g b` per line
//! (numbers separated by blanks or commas, linear 0..1), blank lines, and `#` comments.
//! Names are matched without regard to case.

use glam::DVec3;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// The environment variable naming a user colour file.
pub const COLOURS_ENV: &str = "YARI_COLORS";

/// The built-in names (linear RGB).
const BUILTIN: &[(&str, [f64; 3])] = &[
    ("UNC_Blue", [0.078, 0.361, 0.753]),
    ("white", [1.0, 1.0, 1.0]),
    ("black", [0.0, 0.0, 0.0]),
    ("red", [1.0, 0.0, 0.0]),
    ("green", [0.0, 1.0, 0.0]),
    ("blue", [0.0, 0.0, 1.0]),
    ("yellow", [1.0, 1.0, 0.0]),
    ("cyan", [0.0, 1.0, 1.0]),
    ("magenta", [1.0, 0.0, 1.0]),
    // The thesis's own example: `color=purple` for `color=0.85,0.2,0.85`.
    ("purple", [0.85, 0.2, 0.85]),
    ("orange", [1.0, 0.5, 0.0]),
    ("grey", [0.5, 0.5, 0.5]),
    ("gray", [0.5, 0.5, 0.5]),
    ("light_grey", [0.75, 0.75, 0.75]),
    ("light_gray", [0.75, 0.75, 0.75]),
    ("dark_grey", [0.25, 0.25, 0.25]),
    ("dark_gray", [0.25, 0.25, 0.25]),
    ("brown", [0.6, 0.4, 0.2]),
    ("pink", [1.0, 0.75, 0.8]),
    ("gold", [1.0, 0.84, 0.0]),
    ("silver", [0.75, 0.75, 0.75]),
    ("navy", [0.0, 0.0, 0.5]),
    ("maroon", [0.5, 0.0, 0.0]),
    ("olive", [0.5, 0.5, 0.0]),
    ("teal", [0.0, 0.5, 0.5]),
    ("violet", [0.93, 0.51, 0.93]),
    ("sky_blue", [0.53, 0.81, 0.92]),
    ("forest_green", [0.13, 0.55, 0.13]),
    ("tan", [0.82, 0.71, 0.55]),
    ("ivory", [1.0, 1.0, 0.94]),
];

/// A failed read of a colour file.
#[derive(Debug, thiserror::Error)]
pub enum ColourFileError {
    /// The file could not be read.
    #[error("cannot read colour file {}: {source}", path.display())]
    Io {
        /// The colour file.
        path: PathBuf,
        /// Why it could not be read.
        source: std::io::Error,
    },
    /// A line is not `name r g b` with finite numbers >= 0.
    #[error("{file}:{line}: error: {message}")]
    Syntax {
        /// The colour file, as given.
        file: String,
        /// The line number, from 1.
        line: usize,
        /// What is wrong with the line.
        message: String,
    },
}

/// Colour names to linear RGB.
#[derive(Clone, Debug, PartialEq)]
pub struct ColourTable {
    /// Keyed by the lower-case name; the value keeps the name as written.
    map: HashMap<String, (String, DVec3)>,
}

impl Default for ColourTable {
    fn default() -> Self {
        ColourTable::builtin()
    }
}

impl ColourTable {
    /// The built-in table.
    pub fn builtin() -> ColourTable {
        let mut t = ColourTable {
            map: HashMap::new(),
        };
        for (name, rgb) in BUILTIN {
            t.insert(name, DVec3::from_array(*rgb));
        }
        t
    }

    /// The table for one run: built in, then the file named by `flag`, or if there is no
    /// flag the file named by `$YARI_COLORS` (when set and not empty).
    pub fn for_run(flag: Option<&Path>) -> Result<ColourTable, ColourFileError> {
        let mut t = ColourTable::builtin();
        let env = std::env::var_os(COLOURS_ENV)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from);
        if let Some(path) = flag.map(Path::to_path_buf).or(env) {
            t.load_file(&path)?;
        }
        Ok(t)
    }

    /// Looks a name up, ignoring case.
    pub fn get(&self, name: &str) -> Option<DVec3> {
        self.map.get(&name.to_ascii_lowercase()).map(|(_, c)| *c)
    }

    /// Adds or replaces a name.
    pub fn insert(&mut self, name: &str, rgb: DVec3) {
        self.map
            .insert(name.to_ascii_lowercase(), (name.to_string(), rgb));
    }

    /// All names as written, sorted.
    pub fn names(&self) -> Vec<&str> {
        let mut v: Vec<&str> = self.map.values().map(|(n, _)| n.as_str()).collect();
        v.sort_unstable_by_key(|n| n.to_ascii_lowercase());
        v
    }

    /// The known name closest to `name` in spelling, if any is close.
    pub fn suggest(&self, name: &str) -> Option<&str> {
        let lower = name.to_ascii_lowercase();
        self.map
            .iter()
            .map(|(k, (n, _))| (edit_distance(&lower, k), n.as_str()))
            .filter(|(d, _)| *d <= 2.max(lower.len() / 4))
            .min()
            .map(|(_, n)| n)
    }

    /// Reads a colour file into the table (new names added, known names overridden).
    /// Returns how many names it defined.
    pub fn load_file(&mut self, path: &Path) -> Result<usize, ColourFileError> {
        let text = std::fs::read_to_string(path).map_err(|source| ColourFileError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        self.extend_from_text(&path.display().to_string(), &text)
    }

    /// Reads colour-file text (`file` names it in errors); nothing is changed on an error.
    pub fn extend_from_text(&mut self, file: &str, text: &str) -> Result<usize, ColourFileError> {
        let mut parsed = Vec::new();
        for (i, raw) in text.lines().enumerate() {
            let line = raw.split('#').next().unwrap_or("").trim();
            if line.is_empty() {
                continue;
            }
            let err = |message: String| ColourFileError::Syntax {
                file: file.to_string(),
                line: i + 1,
                message,
            };
            let mut words = line
                .split(|c: char| c.is_whitespace() || c == ',')
                .filter(|w| !w.is_empty());
            let name = words.next().unwrap_or("");
            let valid_name = name
                .chars()
                .next()
                .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
                && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
            if !valid_name {
                return Err(err(format!("`{name}` is not a colour name (letters, digits and `_`, not starting with a digit)")));
            }
            let mut rgb = [0.0; 3];
            for (k, slot) in rgb.iter_mut().enumerate() {
                let word = words
                    .next()
                    .ok_or_else(|| err(format!("`{name}` needs 3 numbers (r g b), found {k}")))?;
                let v: f64 = word
                    .parse()
                    .map_err(|_| err(format!("`{word}` is not a number")))?;
                if !v.is_finite() || v < 0.0 {
                    return Err(err(format!(
                        "colour component `{word}` must be a finite number >= 0"
                    )));
                }
                *slot = v;
            }
            if let Some(extra) = words.next() {
                return Err(err(format!(
                    "unexpected `{extra}` after the 3 numbers of `{name}`"
                )));
            }
            parsed.push((name.to_string(), DVec3::from_array(rgb)));
        }
        let n = parsed.len();
        for (name, rgb) in parsed {
            self.insert(&name, rgb);
        }
        Ok(n)
    }
}

/// Levenshtein distance between two short strings.
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, cb) in b.iter().enumerate() {
            cur[j + 1] = (prev[j] + usize::from(ca != *cb))
                .min(prev[j + 1] + 1)
                .min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_names() {
        let t = ColourTable::builtin();
        assert_eq!(t.get("UNC_Blue"), Some(DVec3::new(0.078, 0.361, 0.753)));
        assert_eq!(t.get("unc_blue"), t.get("UNC_Blue"));
        assert_eq!(t.get("gray"), t.get("grey"));
        assert_eq!(t.get("purple"), Some(DVec3::new(0.85, 0.2, 0.85)));
        assert_eq!(t.get("no_such_colour"), None);
        assert_eq!(t.suggest("reed"), Some("red"));
    }

    #[test]
    fn user_file_extends_and_overrides() {
        let mut t = ColourTable::builtin();
        let n = t
            .extend_from_text(
                "my.colors",
                "# mine\nred 0.9 0.1 0.1\n\nsea_green 0.18,0.55,0.34  # comment\n",
            )
            .unwrap();
        assert_eq!(n, 2);
        assert_eq!(t.get("red"), Some(DVec3::new(0.9, 0.1, 0.1)));
        assert_eq!(t.get("Sea_Green"), Some(DVec3::new(0.18, 0.55, 0.34)));
        assert_eq!(t.get("white"), Some(DVec3::ONE));
    }

    #[test]
    fn user_file_errors_name_file_and_line() {
        let mut t = ColourTable::builtin();
        let e = t
            .extend_from_text("my.colors", "ok 1 1 1\nbad 1 x 1\n")
            .unwrap_err();
        assert_eq!(e.to_string(), "my.colors:2: error: `x` is not a number");
        assert!(t.get("ok").is_none(), "nothing is changed on an error");
        let e = t.extend_from_text("c", "short 1 2\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "c:1: error: `short` needs 3 numbers (r g b), found 2"
        );
        assert!(t.extend_from_text("c", "9lives 1 1 1").is_err());
        assert!(t.extend_from_text("c", "x 1 1 1 1").is_err());
        assert!(t.extend_from_text("c", "x 1 1 -1").is_err());
    }

    #[test]
    fn file_from_flag() {
        let dir = std::env::temp_dir().join(format!("yari-colour-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("c.txt");
        std::fs::write(&path, "chalk 0.9 0.9 0.85\n").unwrap();
        let t = ColourTable::for_run(Some(&path)).unwrap();
        assert_eq!(t.get("chalk"), Some(DVec3::new(0.9, 0.9, 0.85)));
        assert!(matches!(
            ColourTable::for_run(Some(&dir.join("missing"))),
            Err(ColourFileError::Io { .. })
        ));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
