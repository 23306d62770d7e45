//! NFF writer: prints an [`NffScene`] in the layout and number format of Haines's SPD library
//! (`lib_output_*` with C's `%g`, six significant digits), so a generated scene matches the
//! files his programs write.

use super::scene::{Entity, NffScene};
use crate::ast::Vec3;
use std::fmt::Write;

/// The NFF text of a scene.
pub fn write(scene: &NffScene) -> String {
    let mut out = String::new();
    for e in &scene.entities {
        write_entity(&mut out, &e.node);
    }
    out
}

fn write_entity(out: &mut String, e: &Entity) {
    // Writing to a String cannot fail.
    let _ = match e {
        Entity::Background(c) => writeln!(out, "b {}", g3(c)),
        Entity::View(v) => {
            let _ = writeln!(
                out,
                "v\nfrom {}\nat {}\nup {}",
                g3(&v.from),
                g3(&v.at),
                g3(&v.up)
            );
            let _ = writeln!(out, "angle {}\nhither {}", g(v.angle), g(v.hither));
            match v.resolution {
                Some([x, y]) => writeln!(out, "resolution {x} {y}"),
                None => Ok(()),
            }
        }
        Entity::Light {
            position,
            color: None,
        } => writeln!(out, "l {}", g3(position)),
        Entity::Light {
            position,
            color: Some(c),
        } => {
            writeln!(out, "l {} {}", g3(position), g3(c))
        }
        Entity::Fill(f) => writeln!(
            out,
            "f {} {} {} {} {} {}",
            g3(&f.color),
            g(f.kd),
            g(f.ks),
            g(f.shine),
            g(f.t),
            g(f.ior)
        ),
        Entity::Sphere { center, radius } => writeln!(out, "s {} {}", g3(center), g(*radius)),
        Entity::Polygon {
            vertices,
            normals: None,
        } => {
            let _ = writeln!(out, "p {}", vertices.len());
            for v in vertices {
                let _ = writeln!(out, "{}", g3(v));
            }
            Ok(())
        }
        Entity::Polygon {
            vertices,
            normals: Some(normals),
        } => {
            let _ = writeln!(out, "pp {}", vertices.len());
            for (v, n) in vertices.iter().zip(normals) {
                let _ = writeln!(out, "{} {}", g3(v), g3(n));
            }
            Ok(())
        }
        // On one line, as `lib_output_cylcone` prints it (NFF.TXT shows three lines; the
        // reader takes either).
        Entity::Cone {
            base,
            base_radius,
            apex,
            apex_radius,
        } => writeln!(
            out,
            "c {} {} {} {}",
            g3(base),
            g(*base_radius),
            g3(apex),
            g(*apex_radius)
        ),
    };
}

fn g3(v: &Vec3) -> String {
    format!("{} {} {}", g(v[0]), g(v[1]), g(v[2]))
}

/// C's `printf("%g", x)`: six significant digits, trailing zeros removed, exponent form when
/// the decimal exponent is below -4 or at least 6.
pub fn g(x: f64) -> String {
    const PRECISION: i32 = 6;
    if x == 0.0 {
        return if x.is_sign_negative() {
            "-0".into()
        } else {
            "0".into()
        };
    }
    if !x.is_finite() {
        return if x.is_nan() {
            "nan".into()
        } else if x > 0.0 {
            "inf".into()
        } else {
            "-inf".into()
        };
    }
    // The exponent after rounding to PRECISION significant digits decides the style.
    let sci = format!("{:.*e}", (PRECISION - 1) as usize, x);
    let (mantissa, exp) = sci.split_once('e').unwrap_or((&sci, "0"));
    let exp: i32 = exp.parse().unwrap_or(0);
    if (-4..PRECISION).contains(&exp) {
        let decimals = (PRECISION - 1 - exp) as usize;
        strip_zeros(format!("{x:.decimals$}"))
    } else {
        let sign = if exp < 0 { '-' } else { '+' };
        format!(
            "{}e{}{:02}",
            strip_zeros(mantissa.to_string()),
            sign,
            exp.abs()
        )
    }
}

fn strip_zeros(s: String) -> String {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nff::scene::{Fill, View};

    #[test]
    fn percent_g_matches_c() {
        let cases = [
            (1.0, "1"),
            (0.5, "0.5"),
            (-0.96875, "-0.96875"),
            (1.022846, "1.02285"),
            (-0.0160409123, "-0.0160409"),
            (100000.0, "100000"),
            (1000000.0, "1e+06"),
            (0.0001, "0.0001"),
            (0.00001234567, "1.23457e-05"),
            (0.0555555555, "0.0555556"),
            (123456.7, "123457"),
            (999999.5, "1e+06"),
            (-0.0, "-0"),
            (0.0, "0"),
        ];
        for (x, want) in cases {
            assert_eq!(g(x), want, "{x}");
        }
    }

    #[test]
    fn writes_haines_layout() {
        let mut s = NffScene::default();
        s.push(Entity::Background([0.078, 0.361, 0.753]));
        s.push(Entity::View(View {
            from: [2.1, 1.3, 1.7],
            at: [0.0; 3],
            up: [0.0, 0.0, 1.0],
            angle: 45.0,
            hither: 0.01,
            resolution: Some([512, 512]),
        }));
        s.push(Entity::Light {
            position: [4.0, 3.0, 2.0],
            color: None,
        });
        s.push(Entity::Fill(Fill::haines(
            [1.0, 0.75, 0.33],
            0.8,
            0.0,
            0.0,
            0.0,
            1.0,
        )));
        s.push(Entity::Polygon {
            vertices: vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0; 3]],
            normals: None,
        });
        s.push(Entity::Sphere {
            center: [0.0; 3],
            radius: 0.5,
        });
        s.push(Entity::Cone {
            base: [0.0; 3],
            base_radius: 1.0,
            apex: [0.0, 0.0, 2.0],
            apex_radius: 0.0,
        });
        let want = "b 0.078 0.361 0.753\nv\nfrom 2.1 1.3 1.7\nat 0 0 0\nup 0 0 1\nangle 45\n\
                    hither 0.01\nresolution 512 512\nl 4 3 2\nf 1 0.75 0.33 0.8 0 100000 0 1\n\
                    p 3\n1 0 0\n0 1 0\n0 0 0\ns 0 0 0 0.5\nc 0 0 0 1 0 0 2 0\n";
        assert_eq!(write(&s), want);
    }
}
