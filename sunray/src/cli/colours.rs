//! The colour-name flag every scene-reading subcommand shares: `--colors FILE` (alias
//! `--colours`), else `$YARI_COLORS`.

use clap::Args;
use std::path::PathBuf;

/// A colour file extending the built-in colour names.
#[derive(Args, Debug, Clone, Default)]
pub struct ColourArgs {
    /// A colour file (`name r g b` per line) extending the built-in colour names.
    #[arg(
        long = "colors",
        visible_alias = "colours",
        value_name = "FILE",
        env = "YARI_COLORS"
    )]
    pub colors: Option<PathBuf>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct T {
        #[command(flatten)]
        c: ColourArgs,
    }

    #[test]
    fn both_spellings_name_the_file() {
        for flag in ["--colors", "--colours"] {
            let t = T::try_parse_from(["t", flag, "my.col"]).unwrap();
            assert_eq!(t.c.colors, Some(PathBuf::from("my.col")));
        }
    }
}
