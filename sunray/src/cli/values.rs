//! How the library's choices are spelled on the command line: clap's [`ValueEnum`] for the
//! accelerator, the sampler and the line-distribution strategy (the library types know nothing of clap).

use crate::accel::AccelKind;
use crate::distrib::strategy::Strategy;
use crate::sampler::Sampler;
use clap::builder::PossibleValue;
use clap::ValueEnum;

impl ValueEnum for AccelKind {
    fn value_variants<'a>() -> &'a [Self] {
        &[
            AccelKind::Auto,
            AccelKind::Octree,
            AccelKind::Bvh,
            AccelKind::Exhaustive,
        ]
    }

    fn to_possible_value(&self) -> Option<PossibleValue> {
        let v = PossibleValue::new(self.name());
        Some(match self {
            AccelKind::Auto => v.help("the exhaustive search up to 8 primitives, the BVH above"),
            AccelKind::Octree => v.help("Glassner's adaptive octree (thesis section 2.3)"),
            AccelKind::Bvh => v.help("a bounding volume hierarchy built with the SAH"),
            AccelKind::Exhaustive => v.help("every primitive for every ray"),
        })
    }
}

impl ValueEnum for Sampler {
    fn value_variants<'a>() -> &'a [Self] {
        &Sampler::ALL
    }

    fn to_possible_value(&self) -> Option<PossibleValue> {
        let v = PossibleValue::new(self.name());
        Some(match self {
            Sampler::Stratified => v.help("jitter in a grid of the pixel and of every 2-D draw"),
            Sampler::Sobol => v.help("an Owen-scrambled Sobol sequence per pixel (sobol_burley)"),
        })
    }
}

impl ValueEnum for Strategy {
    fn value_variants<'a>() -> &'a [Self] {
        &[Strategy::Dynamic, Strategy::Blocks, Strategy::Interleaved]
    }

    fn to_possible_value(&self) -> Option<PossibleValue> {
        let v = PossibleValue::new(self.name());
        Some(match self {
            Strategy::Dynamic => {
                v.help("SunRay III: each worker asks for the next line when it has room")
            }
            Strategy::Blocks => v.help("SunRay I: n contiguous bands of scanlines, one per node"),
            Strategy::Interleaved => v.help("SunRay II: node i renders lines i, i+n, i+2n, ..."),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_value_parses_back_by_its_library_name() {
        for k in AccelKind::value_variants() {
            assert_eq!(AccelKind::from_str(k.name(), false), Ok(*k));
        }
        for s in Strategy::value_variants() {
            assert_eq!(Strategy::from_str(s.name(), false), Ok(*s));
            assert_eq!(Strategy::from_name(s.name()), Some(*s));
        }
    }
}
