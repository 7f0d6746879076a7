//! Class size priors: typical dimensions of indoor COCO classes, the mapper's own knowledge
//! (household-object catalogue figures, rounded; not read from any scene). Used by the box
//! segmentation ([`super::segment`]) to prefer the depth cluster whose size fits the class, and to
//! bound outlier removal. A class not in the table gets a loose generic prior.

use shm_types::{ClassId, class_name};

/// Typical size of a class: longest horizontal side, shorter horizontal side, height (metres).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SizePrior {
    /// `[long, short, height]`, metres.
    pub size: [f32; 3],
    /// The class is found by its dominant horizontal plane (a table top).
    pub plane: bool,
}

impl SizePrior {
    /// Half the horizontal diagonal, metres.
    pub fn half_diagonal(&self) -> f32 {
        0.5 * (self.size[0] * self.size[0] + self.size[1] * self.size[1]).sqrt()
    }

    /// How well a cluster of horizontal extent `long` × `short` and height `height` fits:
    /// 1 when within the factor-2 band around every prior dimension, falling off as a log-normal
    /// (σ = ln 2) outside; a partial view may be smaller, so shrinking costs half as much.
    pub fn fit(&self, long: f32, short: f32, height: f32) -> f32 {
        let mut e = 0.0f32;
        for (got, want) in [long, short, height].into_iter().zip(self.size) {
            let r = (got.max(1e-3) / want).ln() / std::f32::consts::LN_2;
            let over = (r - 1.0).max(0.0);
            let under = (-r - 1.0).max(0.0) * 0.5;
            e += over * over + under * under;
        }
        (-0.5 * e).exp()
    }
}

const fn p(long: f32, short: f32, height: f32) -> SizePrior {
    SizePrior {
        size: [long, short, height],
        plane: false,
    }
}

/// Typical dimensions of common indoor COCO classes.
const PRIORS: [(&str, SizePrior); 24] = [
    ("cup", p(0.09, 0.08, 0.10)),
    ("bottle", p(0.08, 0.07, 0.25)),
    ("wine glass", p(0.08, 0.08, 0.20)),
    ("vase", p(0.12, 0.12, 0.25)),
    ("bowl", p(0.16, 0.16, 0.07)),
    ("book", p(0.24, 0.17, 0.04)),
    ("laptop", p(0.34, 0.24, 0.22)),
    ("keyboard", p(0.44, 0.14, 0.03)),
    ("mouse", p(0.11, 0.06, 0.04)),
    ("remote", p(0.18, 0.05, 0.03)),
    ("cell phone", p(0.15, 0.07, 0.01)),
    ("clock", p(0.25, 0.08, 0.25)),
    ("teddy bear", p(0.25, 0.18, 0.30)),
    ("potted plant", p(0.30, 0.30, 0.40)),
    ("tv", p(1.00, 0.20, 0.60)),
    ("scissors", p(0.20, 0.08, 0.02)),
    ("backpack", p(0.32, 0.20, 0.45)),
    ("handbag", p(0.30, 0.15, 0.25)),
    ("banana", p(0.20, 0.05, 0.04)),
    ("apple", p(0.08, 0.08, 0.08)),
    ("chair", p(0.55, 0.50, 0.90)),
    ("couch", p(2.00, 0.90, 0.85)),
    ("bed", p(2.00, 1.50, 0.60)),
    (
        "dining table",
        SizePrior {
            size: [1.40, 0.80, 0.75],
            plane: true,
        },
    ),
];

/// Generic prior for a class not in the table.
const GENERIC: SizePrior = p(0.50, 0.50, 0.50);

/// The size prior of a class.
pub fn size_prior(class_id: ClassId) -> SizePrior {
    let name = class_name(class_id);
    PRIORS
        .iter()
        .find(|(n, _)| *n == name)
        .map_or(GENERIC, |(_, s)| *s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use shm_types::class_id;

    #[test]
    fn priors_are_coco_classes_and_fit_prefers_the_right_size() {
        for (n, _) in PRIORS {
            assert!(class_id(n).is_some(), "{n}");
        }
        let cup = size_prior(class_id("cup").unwrap());
        assert!(cup.fit(0.08, 0.08, 0.10) > 0.99);
        assert!(
            cup.fit(0.05, 0.04, 0.10) > 0.9,
            "a partial view is plausible"
        );
        assert!(cup.fit(0.9, 0.3, 0.7) < 0.05, "a table edge is not a cup");
        assert!(size_prior(class_id("dining table").unwrap()).plane);
        assert_eq!(size_prior(class_id("giraffe").unwrap()), GENERIC);
    }
}
