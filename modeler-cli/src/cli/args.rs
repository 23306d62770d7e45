//! Value parsers for the command line: vectors (`1,2,3`), plane points (`1,2`), colours
//! (a name or `r,g,b`), textures, and the principal axes. Each error says what was expected.

use crate::project::{Color, Texture, V3};

/// A principal axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Axis {
    X,
    Y,
    Z,
}

impl Axis {
    pub fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }
}

fn numbers(s: &str, n: usize, what: &str) -> Result<Vec<f64>, String> {
    if s.starts_with("--") {
        // A list of points takes every word after it, so an option there lands here.
        return Err(format!(
            "`{s}` is an option where {what} was expected; put options before a list of points"
        ));
    }
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != n {
        return Err(format!(
            "expected {what} as {n} numbers separated by commas, got `{s}`"
        ));
    }
    parts
        .iter()
        .map(|p| match p.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(format!("`{p}` in `{s}` is not a finite number")),
        })
        .collect()
}

/// `x,y,z`.
pub fn vec3(s: &str) -> Result<V3, String> {
    let v = numbers(s, 3, "x,y,z")?;
    Ok([v[0], v[1], v[2]])
}

/// `u,v`: a point in a skeleton's plane.
pub fn vec2(s: &str) -> Result<[f64; 2], String> {
    let v = numbers(s, 2, "a point u,v")?;
    Ok([v[0], v[1]])
}

/// One finite number.
pub fn number(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(format!("`{s}` is not a finite number")),
    }
}

/// A scale: one factor for all axes, or `sx,sy,sz`; no factor may be zero.
pub fn scale3(s: &str) -> Result<V3, String> {
    let v = if s.contains(',') {
        vec3(s)?
    } else {
        let k = number(s)?;
        [k, k, k]
    };
    if v.contains(&0.0) {
        return Err(format!("scale factors must not be zero (got `{s}`)"));
    }
    Ok(v)
}

/// A clipping plane `a,b,c,d`: keep the points with a*x + b*y + c*z <= d.
pub fn plane4(s: &str) -> Result<(V3, f64), String> {
    let v = numbers(s, 4, "a plane a,b,c,d (keep a*x+b*y+c*z <= d)")?;
    if v[..3].iter().all(|c| *c == 0.0) {
        return Err(format!("the plane `{s}` has a zero normal"));
    }
    Ok(([v[0], v[1], v[2]], v[3]))
}

/// A colour: `r,g,b` (linear, 0..1 usually) or a name from the colour table. Names are
/// checked when the command runs, against the same table the renderer uses.
pub fn color(s: &str) -> Result<Color, String> {
    if s.contains(',') {
        let v = numbers(s, 3, "a colour r,g,b")?;
        if v.iter().any(|c| *c < 0.0) {
            return Err(format!(
                "colour components must not be negative (got `{s}`)"
            ));
        }
        Ok(Color::Rgb([v[0], v[1], v[2]]))
    } else if !s.is_empty()
        && s.chars()
            .all(|c| c.is_alphanumeric() || c == '_' || c == '-')
    {
        Ok(Color::Named(s.to_string()))
    } else {
        Err(format!("expected a colour name or r,g,b, got `{s}`"))
    }
}

/// The texture names for YARI's texture ids (see docs/yari.md).
pub const TEXTURES: [(&str, u32); 5] = [
    ("wood", 1),
    ("marble", 2),
    ("bumps", 3),
    ("turbulence", 4),
    ("checker", 5),
];

/// A parsed `--texture`: a texture, or `None` for `none` (remove it).
#[derive(Clone, Debug, PartialEq)]
pub struct TextureSpec(pub Option<Texture>);

/// [`texture`] for clap.
pub fn texture_spec(s: &str) -> Result<TextureSpec, String> {
    texture(s).map(TextureSpec)
}

/// `ID-or-NAME [r,g,b [sx,sy,sz]]`, or `none`.
pub fn texture(s: &str) -> Result<Option<Texture>, String> {
    let words: Vec<&str> = s.split_whitespace().collect();
    let Some(first) = words.first() else {
        return Err("expected a texture: NAME-or-ID [r,g,b [sx,sy,sz]], or `none`".into());
    };
    if *first == "none" && words.len() == 1 {
        return Ok(None);
    }
    let id = match TEXTURES.iter().find(|(n, _)| n.eq_ignore_ascii_case(first)) {
        Some((_, id)) => *id as f64,
        None => match first.parse::<u32>() {
            Ok(id) => id as f64,
            Err(_) => {
                let names: Vec<&str> = TEXTURES.iter().map(|(n, _)| *n).collect();
                return Err(format!(
                    "unknown texture `{first}` (known: {}, or a number)",
                    names.join(", ")
                ));
            }
        },
    };
    if words.len() > 3 {
        return Err(format!(
            "a texture is NAME-or-ID [r,g,b [sx,sy,sz]]; `{s}` has {} words",
            words.len()
        ));
    }
    let color = match words.get(1) {
        Some(w) => vec3(w)?,
        None => [0.0, 0.0, 0.0],
    };
    let scale = match words.get(2) {
        Some(w) => scale3(w)?,
        None => [1.0, 1.0, 1.0],
    };
    Ok(Some(Texture { id, color, scale }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vectors_numbers_and_scales() {
        assert_eq!(vec3("1, -2,3.5"), Ok([1.0, -2.0, 3.5]));
        assert!(vec3("1,2").unwrap_err().contains("x,y,z"));
        assert!(vec3("1,b,3").unwrap_err().contains("`b`"));
        assert!(vec3("1,inf,3").is_err());
        assert!(vec2("--at").unwrap_err().contains("put options before"));
        assert_eq!(vec2("0.5,2"), Ok([0.5, 2.0]));
        assert_eq!(scale3("2"), Ok([2.0; 3]));
        assert!(scale3("1,0,1").is_err());
        assert_eq!(plane4("0,1,0,2"), Ok(([0.0, 1.0, 0.0], 2.0)));
    }

    #[test]
    fn colours_by_name_or_rgb() {
        assert_eq!(color("red"), Ok(Color::Named("red".into())));
        assert_eq!(color("1,0.5,0"), Ok(Color::Rgb([1.0, 0.5, 0.0])));
        assert!(color("-1,0,0").is_err());
        assert!(color("re d").is_err());
    }

    #[test]
    fn textures_by_name_or_id() {
        let t = texture("wood .5,.4,.3 2,2,2").unwrap().unwrap();
        assert_eq!((t.id, t.color, t.scale), (1.0, [0.5, 0.4, 0.3], [2.0; 3]));
        assert_eq!(texture("5").unwrap().unwrap().id, 5.0);
        assert_eq!(texture("none"), Ok(None));
        assert!(texture("plaid").unwrap_err().contains("marble"));
    }
}
