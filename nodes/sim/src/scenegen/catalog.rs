//! What each kind of room holds: furniture templates (supports) and foreground object classes,
//! with plausible size ranges (household and office furniture catalogue figures, rounded) and
//! materials. Every foreground class has a size prior in `mapper/priors.rs`; the ranges here
//! stay within a factor 1.5 of it.

use crate::{Material, Shape};

/// The kind of room: which furniture and objects it holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Desks, meeting table, shelves; laptops, keyboards, cups, books.
    Office,
    /// Counters, island, dining table, shelves; cups, bowls, bottles, fruit.
    Kitchen,
    /// Coffee and side tables, sideboard, couch; remotes, books, vases, plants.
    Living,
    /// Benches, carts, shelves; laptops, bottles, scissors, backpacks.
    Lab,
}

impl Kind {
    /// Every kind, in the order [`Kind::for_seed`] cycles through them.
    pub const ALL: [Kind; 4] = [Kind::Office, Kind::Kitchen, Kind::Living, Kind::Lab];

    /// Name as used on the command line and in scene names.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Office => "office",
            Kind::Kitchen => "kitchen",
            Kind::Living => "living",
            Kind::Lab => "lab",
        }
    }

    /// The kind named `name`, `None` if none is.
    pub fn from_name(name: &str) -> Option<Kind> {
        Kind::ALL.into_iter().find(|k| k.name() == name)
    }

    /// The kind of seed `seed` when none is asked for: seeds cycle through [`Kind::ALL`]
    /// (1 office, 2 kitchen, 3 living, 4 lab, 5 office, ...), so any 4 consecutive seeds give
    /// every kind.
    pub fn for_seed(seed: u64) -> Kind {
        Kind::ALL[(seed.wrapping_add(3) % 4) as usize]
    }
}

/// Where a piece of furniture stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Placement {
    /// Its back against a room wall.
    Wall,
    /// Free-standing, away from the walls.
    Free,
}

/// A furniture template.
#[derive(Debug, Clone, Copy)]
pub struct Furniture {
    /// Name stem in the scene file.
    pub label: &'static str,
    /// COCO class (a background class).
    pub class: &'static str,
    /// Long side range, metres.
    pub long: (f32, f32),
    /// Short side range, metres.
    pub short: (f32, f32),
    /// Height range, metres.
    pub height: (f32, f32),
    /// Where it stands.
    pub placement: Placement,
    /// Whether a chair may stand at it.
    pub chairs: bool,
}

const fn furn(
    label: &'static str,
    class: &'static str,
    long: (f32, f32),
    short: (f32, f32),
    height: (f32, f32),
    placement: Placement,
    chairs: bool,
) -> Furniture {
    Furniture {
        label,
        class,
        long,
        short,
        height,
        placement,
        chairs,
    }
}

use Placement::{Free, Wall};

// Shelves top out at 1.05 m: the camera (1.4 m high, pitched 28° down, 46.8° vertical FOV) sees
// nothing higher than 4.6° below its horizon.
const OFFICE: [Furniture; 4] = [
    furn(
        "desk",
        "dining table",
        (1.2, 1.8),
        (0.6, 0.8),
        (0.72, 0.76),
        Wall,
        true,
    ),
    furn(
        "meeting_table",
        "dining table",
        (1.4, 2.0),
        (0.8, 1.0),
        (0.72, 0.76),
        Free,
        true,
    ),
    furn(
        "side_table",
        "dining table",
        (0.5, 0.8),
        (0.5, 0.7),
        (0.5, 0.65),
        Free,
        false,
    ),
    furn(
        "shelf",
        "dining table",
        (0.8, 1.2),
        (0.3, 0.4),
        (0.9, 1.05),
        Wall,
        false,
    ),
];
const KITCHEN: [Furniture; 4] = [
    furn(
        "counter",
        "dining table",
        (1.4, 2.2),
        (0.6, 0.65),
        (0.88, 0.92),
        Wall,
        false,
    ),
    furn(
        "island",
        "dining table",
        (1.2, 1.8),
        (0.8, 1.0),
        (0.88, 0.92),
        Free,
        false,
    ),
    furn(
        "dining_table",
        "dining table",
        (0.9, 1.4),
        (0.8, 0.9),
        (0.72, 0.76),
        Free,
        true,
    ),
    furn(
        "shelf",
        "dining table",
        (0.8, 1.2),
        (0.3, 0.4),
        (0.95, 1.05),
        Wall,
        false,
    ),
];
const LIVING: [Furniture; 4] = [
    furn(
        "coffee_table",
        "dining table",
        (0.9, 1.3),
        (0.5, 0.7),
        (0.4, 0.48),
        Free,
        false,
    ),
    furn(
        "side_table",
        "dining table",
        (0.45, 0.6),
        (0.45, 0.6),
        (0.5, 0.6),
        Free,
        false,
    ),
    furn(
        "sideboard",
        "dining table",
        (1.0, 1.6),
        (0.4, 0.45),
        (0.75, 1.0),
        Wall,
        false,
    ),
    furn(
        "couch",
        "couch",
        (1.6, 2.2),
        (0.8, 0.95),
        (0.75, 0.85),
        Wall,
        false,
    ),
];
const LAB: [Furniture; 4] = [
    furn(
        "bench",
        "dining table",
        (1.5, 2.2),
        (0.7, 0.8),
        (0.88, 0.92),
        Wall,
        true,
    ),
    furn(
        "table",
        "dining table",
        (1.2, 1.6),
        (0.7, 0.8),
        (0.72, 0.76),
        Free,
        true,
    ),
    furn(
        "cart",
        "dining table",
        (0.6, 0.8),
        (0.45, 0.5),
        (0.8, 0.9),
        Free,
        false,
    ),
    furn(
        "shelf",
        "dining table",
        (0.9, 1.2),
        (0.35, 0.45),
        (0.95, 1.05),
        Wall,
        false,
    ),
];

/// A chair standing at a desk or table (a solid box, as in paper-scene-3).
pub const CHAIR: Furniture = furn(
    "chair",
    "chair",
    (0.45, 0.55),
    (0.45, 0.52),
    (0.82, 0.92),
    Free,
    false,
);

/// The furniture of a kind.
pub fn furniture(kind: Kind) -> &'static [Furniture] {
    match kind {
        Kind::Office => &OFFICE,
        Kind::Kitchen => &KITCHEN,
        Kind::Living => &LIVING,
        Kind::Lab => &LAB,
    }
}

/// A foreground object class.
#[derive(Debug, Clone, Copy)]
pub struct Item {
    /// COCO class.
    pub class: &'static str,
    /// Long horizontal side range (diameter for cylinders), metres.
    pub long: (f32, f32),
    /// Short horizontal side range (ignored for cylinders), metres.
    pub short: (f32, f32),
    /// Height range, metres.
    pub height: (f32, f32),
    /// Box or upright cylinder.
    pub shape: Shape,
    /// Materials and their weights.
    pub materials: &'static [(Material, u32)],
}

const fn item(
    class: &'static str,
    long: (f32, f32),
    short: (f32, f32),
    height: (f32, f32),
    shape: Shape,
    materials: &'static [(Material, u32)],
) -> Item {
    Item {
        class,
        long,
        short,
        height,
        shape,
        materials,
    }
}

use Material::{Dark, Default as Matte, Glass, Specular};
use Shape::{Box as B, Cylinder as C};

const MATTE: &[(Material, u32)] = &[(Matte, 1)];
const DARK: &[(Material, u32)] = &[(Dark, 1)];

/// Every foreground class the generator places (each has a mapper size prior).
pub const ITEMS: [Item; 19] = [
    item(
        "cup",
        (0.07, 0.10),
        (0.0, 0.0),
        (0.08, 0.12),
        C,
        &[(Matte, 3), (Specular, 2)],
    ),
    item(
        "bottle",
        (0.06, 0.09),
        (0.0, 0.0),
        (0.20, 0.32),
        C,
        &[(Glass, 7), (Matte, 3)],
    ),
    item(
        "wine glass",
        (0.07, 0.09),
        (0.0, 0.0),
        (0.15, 0.22),
        C,
        &[(Glass, 1)],
    ),
    item(
        "vase",
        (0.10, 0.20),
        (0.0, 0.0),
        (0.18, 0.35),
        C,
        &[(Specular, 5), (Glass, 2), (Matte, 3)],
    ),
    item(
        "bowl",
        (0.12, 0.22),
        (0.0, 0.0),
        (0.05, 0.09),
        C,
        &[(Matte, 7), (Specular, 3)],
    ),
    item("book", (0.18, 0.28), (0.13, 0.20), (0.02, 0.05), B, MATTE),
    item("laptop", (0.30, 0.38), (0.21, 0.26), (0.20, 0.24), B, DARK),
    item(
        "keyboard",
        (0.38, 0.46),
        (0.12, 0.16),
        (0.025, 0.04),
        B,
        DARK,
    ),
    item("mouse", (0.09, 0.12), (0.055, 0.07), (0.03, 0.045), B, DARK),
    item("remote", (0.15, 0.21), (0.04, 0.06), (0.02, 0.03), B, DARK),
    item(
        "cell phone",
        (0.13, 0.16),
        (0.065, 0.08),
        (0.008, 0.012),
        B,
        DARK,
    ),
    item("clock", (0.20, 0.28), (0.06, 0.10), (0.20, 0.28), B, MATTE),
    item(
        "teddy bear",
        (0.20, 0.30),
        (0.15, 0.20),
        (0.25, 0.35),
        B,
        MATTE,
    ),
    item(
        "potted plant",
        (0.15, 0.30),
        (0.0, 0.0),
        (0.25, 0.45),
        C,
        MATTE,
    ),
    item(
        "scissors",
        (0.16, 0.22),
        (0.06, 0.09),
        (0.015, 0.02),
        B,
        MATTE,
    ),
    item(
        "backpack",
        (0.28, 0.36),
        (0.16, 0.24),
        (0.38, 0.48),
        B,
        &[(Dark, 1), (Matte, 1)],
    ),
    item(
        "handbag",
        (0.25, 0.35),
        (0.12, 0.18),
        (0.20, 0.30),
        B,
        &[(Dark, 1), (Matte, 1)],
    ),
    item("apple", (0.07, 0.09), (0.0, 0.0), (0.07, 0.09), C, MATTE),
    item(
        "banana",
        (0.17, 0.22),
        (0.04, 0.06),
        (0.035, 0.05),
        B,
        MATTE,
    ),
];

/// The foreground classes of a kind and their weights (indices into [`ITEMS`]).
pub fn items(kind: Kind) -> &'static [(usize, u32)] {
    match kind {
        // cup, bottle, book, laptop, keyboard, mouse, cell phone, clock, potted plant, scissors, vase
        Kind::Office => &[
            (0, 3),
            (1, 2),
            (5, 3),
            (6, 2),
            (7, 2),
            (8, 2),
            (10, 1),
            (11, 1),
            (13, 1),
            (14, 1),
            (3, 1),
        ],
        // cup, bottle, wine glass, vase, bowl, apple, banana, potted plant, cell phone
        Kind::Kitchen => &[
            (0, 3),
            (1, 3),
            (2, 2),
            (3, 1),
            (4, 3),
            (17, 2),
            (18, 2),
            (13, 1),
            (10, 1),
        ],
        // remote, book, vase, potted plant, cup, teddy bear, clock, cell phone, bowl, handbag
        Kind::Living => &[
            (9, 3),
            (5, 3),
            (3, 2),
            (13, 2),
            (0, 2),
            (12, 1),
            (11, 1),
            (10, 1),
            (4, 1),
            (16, 1),
        ],
        // laptop, keyboard, mouse, bottle, cup, book, scissors, cell phone, backpack, bowl
        Kind::Lab => &[
            (6, 2),
            (7, 1),
            (8, 1),
            (1, 3),
            (0, 2),
            (5, 2),
            (14, 1),
            (10, 1),
            (15, 1),
            (4, 1),
        ],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_class_is_coco_and_backgrounds_are_background() {
        for it in ITEMS {
            let id = shm_types::class_id(it.class).unwrap();
            assert!(!shm_types::is_background_class(id), "{}", it.class);
            assert!(it.long.0 <= it.long.1 && it.height.0 <= it.height.1);
        }
        for kind in Kind::ALL {
            assert_eq!(Kind::from_name(kind.name()), Some(kind));
            for f in furniture(kind).iter().chain([&CHAIR]) {
                let id = shm_types::class_id(f.class).unwrap();
                assert!(shm_types::is_background_class(id), "{}", f.class);
                assert!(f.height.1 <= 1.05, "{}: too high for the camera", f.label);
            }
            assert!(items(kind).iter().all(|(i, w)| *i < ITEMS.len() && *w > 0));
        }
        assert_eq!(Kind::for_seed(1), Kind::Office);
        assert_eq!(Kind::for_seed(4), Kind::Lab);
        assert_eq!(Kind::for_seed(5), Kind::Office);
    }
}
