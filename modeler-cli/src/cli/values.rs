//! How the library's choices are spelled on the command line: clap's [`ValueEnum`] for the
//! principal planes, skeleton kinds and preview styles (the library types know nothing of
//! clap).

use crate::preview::Style;
use crate::skeleton::{Plane, SkeletonKind};
use clap::builder::PossibleValue;
use clap::ValueEnum;

impl ValueEnum for Plane {
    fn value_variants<'a>() -> &'a [Self] {
        &[Plane::Xy, Plane::Xz, Plane::Yz]
    }

    fn to_possible_value(&self) -> Option<PossibleValue> {
        Some(match self {
            Plane::Xy => PossibleValue::new("xy").help("x,y (the front view); depth is z"),
            Plane::Xz => PossibleValue::new("xz").help("x,z (the top view); depth is y"),
            Plane::Yz => PossibleValue::new("yz").help("y,z (the side view); depth is x"),
        })
    }
}

impl ValueEnum for SkeletonKind {
    fn value_variants<'a>() -> &'a [Self] {
        &[
            SkeletonKind::Points,
            SkeletonKind::Lines,
            SkeletonKind::Bezier,
        ]
    }

    fn to_possible_value(&self) -> Option<PossibleValue> {
        Some(match self {
            SkeletonKind::Points => PossibleValue::new("points")
                .help("Separate points (a sphere's centre and surface point, for instance)"),
            SkeletonKind::Lines => {
                PossibleValue::new("lines").help("Line segments joining the points in order")
            }
            SkeletonKind::Bezier => PossibleValue::new("bezier")
                .help("A chain of Bézier pieces with the points as control points"),
        })
    }
}

impl ValueEnum for Style {
    fn value_variants<'a>() -> &'a [Self] {
        &[Style::Wire, Style::Flat]
    }

    fn to_possible_value(&self) -> Option<PossibleValue> {
        Some(match self {
            Style::Wire => PossibleValue::new("wire")
                .help("Polygon edges (and contour slices of quadrics), everything visible"),
            Style::Flat => {
                PossibleValue::new("flat").help("Flat-shaded faces, hidden surfaces removed")
            }
        })
    }
}
