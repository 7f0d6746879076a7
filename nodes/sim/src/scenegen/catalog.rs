//! What each kind of room holds: furniture templates (supports) and foreground object classes,
//! their sizes and materials.
//!
//! **Sizes come from outside sources**: standards (EN 527-1 desk heights, EN 1116 kitchen
//! worktops, ISO 216 paper, ISO 3591 tasting glass, EU banana grades), product lines' spec
//! sheets and furniture catalogues (IKEA, laptop and phone makers), each range with its source
//! in [`Furniture::source`] and [`Item::source`] and the table in `docs/simulator.md`. They keep
//! the products' real spread. They are not taken from, or checked against, what any node of the
//! robot (the mapper's size priors) believes about a class.
//!
//! **Axes and units.** Every range is metres. `length` is the object's own x side (the longer
//! horizontal side where the ranges do not overlap; a cylinder's diameter), `width` its y side
//! (a cylinder's diameter again: the generator sets it to the drawn length), `height` its
//! vertical z extent. An object lying flat (a book, a phone) has its thickness as height.
//!
//! **Distribution.** A class has one or more size families ([`Dims`]): products that come in a
//! few standard sizes (bottles by volume, laptops by screen diagonal, books by paper format,
//! keyboards by layout; bowls, clocks and plants by kind) have one family per size, the rest one
//! family over the catalogue range. A draw picks a family with equal probability, then each axis
//! uniformly in its range, independently, from the room's seeded stream (so a seed still gives
//! the same room).

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

/// A size range per axis, metres: `length` along the object's x, `width` along its y,
/// `height` along z (see the module docs). Each is `(min, max)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dims {
    /// Length (x side; a cylinder's diameter), metres.
    pub length: (f32, f32),
    /// Width (y side; ignored for cylinders, whose width is their length), metres.
    pub width: (f32, f32),
    /// Height (z), metres.
    pub height: (f32, f32),
}

const fn dims(length: (f32, f32), width: (f32, f32), height: (f32, f32)) -> Dims {
    Dims {
        length,
        width,
        height,
    }
}

impl Dims {
    /// Whether `size` (`[length, width, height]`, metres) lies in the ranges, within `tol`.
    pub fn contains(&self, size: [f32; 3], tol: f32) -> bool {
        [self.length, self.width, self.height]
            .iter()
            .zip(size)
            .all(|((lo, hi), v)| v >= lo - tol && v <= hi + tol)
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
    /// Size ranges: length (the side along a wall for wall pieces), width (depth), height.
    pub dims: Dims,
    /// Where it stands.
    pub placement: Placement,
    /// Whether a chair may stand at it.
    pub chairs: bool,
    /// Where the ranges come from.
    pub source: &'static str,
}

use Placement::{Free, Wall};

// Heights top out at 1.05 m: the camera (1.4 m high, pitched 28° down, 46.8° vertical FOV) sees
// nothing higher than 4.6° below its horizon, so a support's top must be lower for the objects on
// it to be seen. Shelving and sideboards are the low units of their catalogues for that reason
// (a 2 m bookcase carries its objects out of view); the cap is the robot's, not a size belief.

const LOW_SHELF: Furniture = Furniture {
    label: "shelf",
    class: "dining table",
    dims: dims((0.77, 1.47), (0.28, 0.40), (0.77, 1.05)),
    placement: Wall,
    chairs: false,
    source: "low bookcases and shelving units, IKEA Kallax 2×2 77×39×77 cm and 4×2 147×39×77 cm, \
             Billy 80×28×106 cm (height capped at 1.05 m, the camera limit)",
};
const OFFICE: [Furniture; 4] = [
    Furniture {
        label: "desk",
        class: "dining table",
        dims: dims((1.0, 1.8), (0.6, 0.8), (0.72, 0.76)),
        placement: Wall,
        chairs: true,
        source: "height EN 527-1:2011, 740 ± 20 mm; top 1.0–1.8 × 0.6–0.8 m: office desk \
                 catalogues (IKEA Bekant 120×80 and 160×80 cm, Lagkapten 120×60 and 140×60 cm)",
    },
    Furniture {
        label: "meeting_table",
        class: "dining table",
        dims: dims((1.4, 2.4), (0.8, 1.2), (0.72, 0.76)),
        placement: Free,
        chairs: true,
        source: "height EN 527-1:2011, 740 ± 20 mm; top: 4–8 seats at 0.6 m of edge each \
                 (Neufert, Architects' Data), 0.8–1.2 m across",
    },
    Furniture {
        label: "side_table",
        class: "dining table",
        dims: dims((0.45, 0.8), (0.4, 0.6), (0.45, 0.65)),
        placement: Free,
        chairs: false,
        source: "side and occasional tables in furniture catalogues (IKEA Lack 55×55×45 cm up to \
                 80×60 cm tops at desk-return height 0.65 m)",
    },
    LOW_SHELF,
];
const KITCHEN: [Furniture; 4] = [
    Furniture {
        label: "counter",
        class: "dining table",
        dims: dims((1.2, 2.4), (0.6, 0.65), (0.85, 0.95)),
        placement: Wall,
        chairs: false,
        source: "EN 1116:2004 (kitchen furniture, co-ordinating sizes): worktop height 850–950 mm, \
                 base units 600 mm deep under a 600–650 mm worktop (IKEA Metod 63.5 cm); 2–4 base \
                 units of 0.6 m along the wall",
    },
    Furniture {
        label: "island",
        class: "dining table",
        dims: dims((1.2, 2.4), (0.6, 1.2), (0.85, 0.95)),
        placement: Free,
        chairs: false,
        source: "height EN 1116:2004, 850–950 mm; top: one or two rows of 0.6 m deep base units, \
                 2–4 units long (IKEA Metod islands)",
    },
    Furniture {
        label: "dining_table",
        class: "dining table",
        dims: dims((0.75, 1.8), (0.75, 1.0), (0.72, 0.76)),
        placement: Free,
        chairs: true,
        source: "height 720–760 mm (dining tables, as EN 527-1 desks); top: 2–6 seats at 0.6 m of \
                 edge each, 0.75–1.0 m across (Neufert, Architects' Data; IKEA Ekedalen, Melltorp \
                 75×75 cm, Lisabo)",
    },
    LOW_SHELF,
];
const LIVING: [Furniture; 4] = [
    Furniture {
        label: "coffee_table",
        class: "dining table",
        dims: dims((0.75, 1.4), (0.5, 0.8), (0.35, 0.5)),
        placement: Free,
        chairs: false,
        source: "coffee tables in furniture catalogues (IKEA Lack 90×55×45 cm and 118×78×45 cm, \
                 Hemnes 118×75×46 cm); heights 35–50 cm",
    },
    Furniture {
        label: "side_table",
        class: "dining table",
        dims: dims((0.35, 0.6), (0.35, 0.6), (0.45, 0.65)),
        placement: Free,
        chairs: false,
        source: "sofa side tables in furniture catalogues (IKEA Lack 55×55×45 cm); up to sofa-arm \
                 height 0.65 m",
    },
    Furniture {
        label: "sideboard",
        class: "dining table",
        dims: dims((1.0, 2.0), (0.38, 0.5), (0.6, 1.05)),
        placement: Wall,
        chairs: false,
        source: "sideboards and low storage units in furniture catalogues (IKEA Bestå, Hemnes): \
                 1.0–2.0 m long, 38–50 cm deep, 0.6–1.05 m high (capped: the camera limit)",
    },
    Furniture {
        label: "couch",
        class: "couch",
        dims: dims((1.5, 2.3), (0.8, 1.0), (0.65, 0.9)),
        placement: Wall,
        chairs: false,
        source: "2–3 seat sofas in furniture catalogues (IKEA Klippan 2-seat 180×88×66 cm, Ektorp \
                 3-seat 218×88×88 cm); the box is the back's height",
    },
];
const LAB: [Furniture; 4] = [
    Furniture {
        label: "bench",
        class: "dining table",
        dims: dims((1.2, 2.4), (0.6, 0.9), (0.85, 0.95)),
        placement: Wall,
        chairs: true,
        source: "EN 13150:2001 (laboratory workbenches): standing height 900 mm, 600–900 mm deep; \
                 lengths in modules of 1.2–2.4 m; heights 850–950 mm across lab-furniture \
                 catalogues",
    },
    Furniture {
        label: "table",
        class: "dining table",
        dims: dims((1.2, 1.8), (0.6, 0.9), (0.72, 0.76)),
        placement: Free,
        chairs: true,
        source: "EN 13150:2001 sitting height 720–750 mm (as EN 527-1, 740 ± 20 mm); 600–900 mm \
                 deep, 1.2–1.8 m long",
    },
    Furniture {
        label: "cart",
        class: "dining table",
        dims: dims((0.45, 1.0), (0.35, 0.6), (0.78, 1.0)),
        placement: Free,
        chairs: false,
        source: "utility and lab carts in catalogues: 2–3 shelf trolleys from IKEA Råskog \
                 45×35×78 cm to 1.0×0.6×1.0 m steel service carts",
    },
    LOW_SHELF,
];

/// A chair standing at a desk or table (a solid box, as in paper-scene-3).
pub const CHAIR: Furniture = Furniture {
    label: "chair",
    class: "chair",
    dims: dims((0.39, 0.55), (0.45, 0.58), (0.77, 1.05)),
    placement: Free,
    chairs: false,
    source: "dining and side chairs in furniture catalogues (IKEA Adde 39×47×77 cm, Stefan \
             42×49×90 cm, upholstered chairs to 55×58 cm and 1.0 m); seat height 0.40–0.51 m \
             (EN 1335-1 office chairs) is inside the box; office chairs to 1.2 m are left out \
             (camera limit 1.05 m)",
};

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
    /// Size families, each as likely (see the module docs).
    pub sizes: &'static [Dims],
    /// Box or upright cylinder.
    pub shape: Shape,
    /// Materials and their weights.
    pub materials: &'static [(Material, u32)],
    /// Where the ranges come from.
    pub source: &'static str,
}

impl Item {
    /// The smallest ranges holding every family: the class's catalogue range.
    pub fn range(&self) -> Dims {
        let hull = |f: fn(&Dims) -> (f32, f32)| {
            self.sizes
                .iter()
                .map(f)
                .fold((f32::MAX, f32::MIN), |a, b| (a.0.min(b.0), a.1.max(b.1)))
        };
        dims(hull(|d| d.length), hull(|d| d.width), hull(|d| d.height))
    }
}

use Material::{Dark, Default as Matte, Glass, Specular};
use Shape::{Box as B, Cylinder as C};

const MATTE: &[(Material, u32)] = &[(Matte, 1)];
const DARK: &[(Material, u32)] = &[(Dark, 1)];

/// A cylinder's family: diameter and height ranges, metres.
const fn cyl(diameter: (f32, f32), height: (f32, f32)) -> Dims {
    dims(diameter, diameter, height)
}

/// Every foreground class the generator places.
pub const ITEMS: [Item; 19] = [
    Item {
        class: "cup",
        sizes: &[cyl((0.06, 0.09), (0.06, 0.12))],
        shape: C,
        materials: &[(Matte, 3), (Specular, 2)],
        source: "mugs and cups, handle left out: sublimation mug blanks 11 oz ∅82×95 mm and 15 oz \
                 ∅86×115 mm; espresso and tea cups ∅60–90 mm, 60–80 mm high (tableware \
                 catalogues)",
    },
    Item {
        class: "bottle",
        sizes: &[
            cyl((0.058, 0.064), (0.21, 0.24)),
            cyl((0.063, 0.070), (0.20, 0.23)),
            cyl((0.073, 0.080), (0.29, 0.31)),
            cyl((0.085, 0.095), (0.30, 0.34)),
        ],
        shape: C,
        materials: &[(Glass, 7), (Matte, 3)],
        source: "beverage bottles by volume: 330 ml glass longneck ∅58–64 × 210–240 mm, 500 ml \
                 PET ∅63–70 × 200–230 mm, 750 ml wine (Bordeaux/Burgundy) ∅73–80 × 290–310 mm, \
                 1.5 l PET ∅85–95 × 300–340 mm (bottle makers' standard ware)",
    },
    Item {
        class: "wine glass",
        sizes: &[cyl((0.065, 0.10), (0.15, 0.25))],
        shape: C,
        materials: &[(Glass, 1)],
        source: "ISO 3591:1977 tasting glass 155 mm high, bowl ∅65 mm, up to Bordeaux glasses \
                 ~250 mm high, ∅100 mm (stemware catalogues)",
    },
    Item {
        class: "vase",
        sizes: &[cyl((0.08, 0.20), (0.12, 0.40))],
        shape: C,
        materials: &[(Specular, 5), (Glass, 2), (Matte, 3)],
        source: "tabletop vases in home-furnishing catalogues (IKEA): ∅8–20 cm, 12–40 cm high; \
                 no standard, a catalogue survey, rounded",
    },
    Item {
        class: "bowl",
        sizes: &[
            cyl((0.12, 0.17), (0.045, 0.08)),
            cyl((0.20, 0.28), (0.07, 0.12)),
        ],
        shape: C,
        materials: &[(Matte, 7), (Specular, 3)],
        source: "tableware catalogues: cereal and soup bowls ∅12–17 cm × 4.5–8 cm (IKEA 365+ \
                 ∅16 cm), serving and salad bowls ∅20–28 cm × 7–12 cm",
    },
    Item {
        class: "book",
        sizes: &[
            dims((0.175, 0.19), (0.105, 0.115), (0.008, 0.05)),
            dims((0.21, 0.25), (0.14, 0.176), (0.008, 0.05)),
            dims((0.279, 0.297), (0.21, 0.216), (0.008, 0.05)),
        ],
        shape: B,
        materials: MATTE,
        source: "lying flat; mass-market paperback 106×175 mm and up; ISO 216 A5 148×210 to B5 \
                 176×250 mm with trade formats 140×216 and 152×229 mm; A4 210×297 mm and US \
                 letter 216×279 mm; thickness 8–50 mm: about 120–900 pages at ~0.1 mm per \
                 80 g/m² leaf, with covers",
    },
    Item {
        class: "laptop",
        sizes: &[
            dims((0.30, 0.315), (0.205, 0.225), (0.195, 0.215)),
            dims((0.315, 0.33), (0.215, 0.235), (0.20, 0.225)),
            dims((0.355, 0.365), (0.235, 0.26), (0.22, 0.245)),
            dims((0.39, 0.40), (0.26, 0.28), (0.25, 0.275)),
        ],
        shape: B,
        materials: DARK,
        source: "open, by 16:9 screen diagonal 13.3, 14, 15.6, 17.3 in: base footprints from \
                 makers' spec sheets (MacBook Air 13 304×215 mm, ThinkPad, Latitude, XPS lines); \
                 height = base 15–25 mm + lid (panel 0.49 × diagonal + bezels) at 100–110°",
    },
    Item {
        class: "keyboard",
        sizes: &[
            dims((0.418, 0.46), (0.115, 0.16), (0.011, 0.04)),
            dims((0.35, 0.37), (0.125, 0.14), (0.025, 0.04)),
            dims((0.279, 0.32), (0.10, 0.12), (0.011, 0.03)),
        ],
        shape: B,
        materials: DARK,
        source: "by layout (keys on the 19.05 mm pitch of ISO/IEC 9995): full-size 104/105 keys \
                 418–460 × 115–160 mm (Apple Magic Keyboard with keypad 419×115×11 mm, Logitech \
                 K120 450×155×24 mm), tenkeyless 350–370 × 125–140 mm, compact 279–320 × \
                 100–120 mm (Apple Magic Keyboard 279×115×11 mm)",
    },
    Item {
        class: "mouse",
        sizes: &[dims((0.09, 0.13), (0.055, 0.085), (0.02, 0.052))],
        shape: B,
        materials: DARK,
        source: "makers' spec sheets: Logitech M185 99×60×39 mm, Apple Magic Mouse \
                 114×57×22 mm, Logitech MX Master 3 125×84×51 mm",
    },
    Item {
        class: "remote",
        sizes: &[dims((0.13, 0.24), (0.035, 0.06), (0.009, 0.03))],
        shape: B,
        materials: DARK,
        source: "TV and media remotes, makers' spec sheets: Apple Siri Remote 136×35×9 mm up to \
                 full-keypad TV remotes ~240×60×30 mm",
    },
    Item {
        class: "cell phone",
        sizes: &[dims((0.13, 0.165), (0.064, 0.08), (0.007, 0.013))],
        shape: B,
        materials: DARK,
        source: "lying flat; smartphones 2017–2024, makers' spec sheets: iPhone 13 mini \
                 131.5×64.2×7.65 mm, iPhone SE 138.4×67.3×7.3 mm, Galaxy S24 Ultra \
                 162.3×79×8.6 mm; a case adds up to ~4 mm",
    },
    Item {
        class: "clock",
        sizes: &[
            dims((0.08, 0.16), (0.04, 0.08), (0.08, 0.16)),
            dims((0.20, 0.35), (0.07, 0.12), (0.15, 0.30)),
        ],
        shape: B,
        materials: MATTE,
        source: "standing clocks in retail catalogues: alarm clocks 8–16 cm wide and high, \
                 mantel clocks 20–35 cm wide, 15–30 cm high; a catalogue survey, rounded",
    },
    Item {
        class: "teddy bear",
        sizes: &[dims((0.12, 0.35), (0.10, 0.25), (0.15, 0.40))],
        shape: B,
        materials: MATTE,
        source: "sitting; soft toys are sold by standing height, 20–60 cm in toy catalogues \
                 (Steiff, IKEA Djungelskog), sitting about 2/3 of it",
    },
    Item {
        class: "potted plant",
        sizes: &[
            cyl((0.09, 0.20), (0.15, 0.30)),
            cyl((0.14, 0.35), (0.25, 0.60)),
        ],
        shape: C,
        materials: MATTE,
        source: "houseplants sold by nursery pot diameter and height (garden-centre and IKEA \
                 listings: pot ∅9–12 cm, 15–30 cm high; pot ∅14–17 cm, 25–60 cm high); the \
                 cylinder's diameter is the foliage spread, at least the pot's",
    },
    Item {
        class: "scissors",
        sizes: &[dims((0.13, 0.25), (0.05, 0.10), (0.008, 0.02))],
        shape: B,
        materials: MATTE,
        source: "lying flat; sold by overall length 5–10 in (13–25 cm; Fiskars and office \
                 catalogues), handles 5–10 cm across",
    },
    Item {
        class: "backpack",
        sizes: &[dims((0.26, 0.35), (0.12, 0.25), (0.38, 0.52))],
        shape: B,
        materials: &[(Dark, 1), (Matte, 1)],
        source: "standing; daypacks 15–30 l from Fjällräven Kånken 27×13×38 cm up to the IATA \
                 cabin-baggage guideline 56×45×25 cm's 25 cm depth; 26–35 cm wide, 38–52 cm high \
                 in outdoor catalogues",
    },
    Item {
        class: "handbag",
        sizes: &[dims((0.20, 0.40), (0.08, 0.18), (0.15, 0.32))],
        shape: B,
        materials: &[(Dark, 1), (Matte, 1)],
        source: "standing, handles left out; handbags and totes in fashion retail catalogues: \
                 20–40 cm wide, 8–18 cm deep, 15–32 cm high; a catalogue survey, rounded",
    },
    Item {
        class: "apple",
        sizes: &[cyl((0.06, 0.09), (0.055, 0.085))],
        shape: C,
        materials: MATTE,
        source: "UNECE standard FFV-50 (apples): sized by diameter, class minimums 50–70 mm by \
                 class and variety group; retail grades to about 90 mm; height about 0.9 × \
                 diameter",
    },
    Item {
        class: "banana",
        sizes: &[dims((0.14, 0.23), (0.04, 0.07), (0.03, 0.045))],
        shape: B,
        materials: MATTE,
        source: "Commission Regulation (EU) No 1333/2011 (bananas): length at least 14 cm, grade \
                 (thickness) at least 27 mm; retail fingers 14–23 cm along the curve's chord, \
                 the curve's bounding box 4–7 cm wide",
    },
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

    fn ordered(d: &Dims) -> bool {
        [d.length, d.width, d.height]
            .iter()
            .all(|(lo, hi)| *lo > 0.0 && lo <= hi)
    }

    #[test]
    fn every_class_is_coco_and_backgrounds_are_background() {
        for it in ITEMS {
            let id = shm_types::class_id(it.class).unwrap();
            assert!(!shm_types::is_background_class(id), "{}", it.class);
            assert!(
                !it.sizes.is_empty() && it.sizes.iter().all(ordered),
                "{}",
                it.class
            );
            assert!(!it.source.is_empty(), "{}: no source", it.class);
            if it.shape == Shape::Cylinder {
                assert!(it.sizes.iter().all(|d| d.length == d.width), "{}", it.class);
            }
        }
        for kind in Kind::ALL {
            assert_eq!(Kind::from_name(kind.name()), Some(kind));
            for f in furniture(kind).iter().chain([&CHAIR]) {
                let id = shm_types::class_id(f.class).unwrap();
                assert!(shm_types::is_background_class(id), "{}", f.class);
                assert!(ordered(&f.dims) && !f.source.is_empty(), "{}", f.label);
                assert!(
                    f.dims.height.1 <= 1.05,
                    "{}: too high for the camera",
                    f.label
                );
            }
            assert!(items(kind).iter().all(|(i, w)| *i < ITEMS.len() && *w > 0));
        }
        assert_eq!(Kind::for_seed(1), Kind::Office);
        assert_eq!(Kind::for_seed(4), Kind::Lab);
        assert_eq!(Kind::for_seed(5), Kind::Office);
    }

    #[test]
    fn an_items_range_is_the_hull_of_its_families() {
        let bottle = ITEMS.iter().find(|i| i.class == "bottle").unwrap();
        let r = bottle.range();
        assert_eq!(r.length, (0.058, 0.095));
        assert_eq!(r.height, (0.20, 0.34));
        assert!(r.contains([0.076, 0.076, 0.30], 0.0));
        assert!(!r.contains([0.076, 0.076, 0.35], 0.0005));
    }
}
