//! The transparent volumes a ray travels inside, innermost last: a glass ball inside a
//! water-filled sphere refracts from water into glass and back into water, not via air, and
//! a ray between the two is dimmed by the water's transmissivity.
//!
//! A volume is known by its surface (its closed shape's attribute); entering one pushes it,
//! leaving it removes the innermost entry with that surface. Up to [`DEPTH`] levels are kept;
//! a ray nested deeper forgets the outermost.

use crate::geometry::Real;

/// Nesting levels kept.
pub const DEPTH: usize = 4;

/// One volume: its surface, refractive index and transmissivity per unit length.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Medium {
    /// The surface index of the volume's closed shape (how leaving it is recognised).
    pub surface: u32,
    /// Refractive index inside the volume (air is 1).
    pub refract: Real,
    /// Fraction of light kept per unit length inside, in [0, 1]; 1 = no absorption.
    pub transmissivity: Real,
}

/// The volumes around a ray; empty is air (index 1, no loss).
#[derive(Clone, Copy, Debug, Default)]
pub struct Media {
    inside: [Medium; DEPTH],
    len: usize,
}

impl PartialEq for Media {
    fn eq(&self, other: &Media) -> bool {
        self.inside[..self.len] == other.inside[..other.len]
    }
}

impl Media {
    /// Outside everything.
    pub const AIR: Media = Media {
        inside: [Medium {
            surface: 0,
            refract: 1.0,
            transmissivity: 1.0,
        }; DEPTH],
        len: 0,
    };

    fn innermost(&self) -> Option<&Medium> {
        self.inside[..self.len].last()
    }

    /// Refractive index around the ray (1 in air).
    pub fn index(&self) -> Real {
        self.innermost().map_or(1.0, |m| m.refract)
    }

    /// Transmissivity per unit length around the ray (None in air).
    pub fn transmissivity(&self) -> Option<Real> {
        self.innermost().map(|m| m.transmissivity)
    }

    /// Whether the ray is inside a volume of `surface`.
    pub fn contains(&self, surface: u32) -> bool {
        self.inside[..self.len].iter().any(|m| m.surface == surface)
    }

    /// The media after entering `m`.
    pub fn entering(mut self, m: Medium) -> Media {
        if self.len == DEPTH {
            self.inside.copy_within(1.., 0);
            self.len -= 1;
        }
        self.inside[self.len] = m;
        self.len += 1;
        self
    }

    /// The media after leaving the innermost volume of `surface` (unchanged if not inside one).
    pub fn leaving(mut self, surface: u32) -> Media {
        if let Some(k) = self.inside[..self.len]
            .iter()
            .rposition(|m| m.surface == surface)
        {
            self.inside.copy_within(k + 1..self.len, k);
            self.len -= 1;
        }
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn m(surface: u32, refract: Real) -> Medium {
        Medium {
            surface,
            refract,
            transmissivity: 0.5 + surface as Real * 0.1,
        }
    }

    #[test]
    fn nested_volumes_come_and_go_in_order() {
        let air = Media::AIR;
        assert_eq!((air.index(), air.transmissivity()), (1.0, None));
        let water = air.entering(m(1, 1.33));
        let glass = water.entering(m(2, 1.5));
        assert_eq!(glass.index(), 1.5);
        assert_eq!(glass.transmissivity(), Some(0.7));
        assert!(glass.contains(1) && glass.contains(2));
        assert_eq!(glass.leaving(2), water);
        assert_eq!(glass.leaving(2).leaving(1), air);
        // Leaving the outer volume first (overlapping shapes) keeps the inner one.
        assert_eq!(glass.leaving(1).index(), 1.5);
        // Leaving what it is not inside changes nothing.
        assert_eq!(water.leaving(7), water);
    }

    #[test]
    fn too_deep_forgets_the_outermost() {
        let mut media = Media::AIR;
        for s in 0..(DEPTH as u32 + 2) {
            media = media.entering(m(s, 1.0 + s as Real));
        }
        assert!(!media.contains(0) && !media.contains(1));
        assert_eq!(media.index(), 1.0 + (DEPTH + 1) as Real);
        for s in (2..(DEPTH as u32 + 2)).rev() {
            media = media.leaving(s);
        }
        assert_eq!(media, Media::AIR);
    }
}
