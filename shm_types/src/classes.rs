//! COCO class table (YOLO order, ids 0..79) shared by the simulator, mapper, planner and tools.

/// Index into [`COCO_CLASSES`].
pub type ClassId = u16;

/// The 80 COCO class names in the order YOLO models emit them.
pub const COCO_CLASSES: [&str; 80] = [
    "person",
    "bicycle",
    "car",
    "motorcycle",
    "airplane",
    "bus",
    "train",
    "truck",
    "boat",
    "traffic light",
    "fire hydrant",
    "stop sign",
    "parking meter",
    "bench",
    "bird",
    "cat",
    "dog",
    "horse",
    "sheep",
    "cow",
    "elephant",
    "bear",
    "zebra",
    "giraffe",
    "backpack",
    "umbrella",
    "handbag",
    "tie",
    "suitcase",
    "frisbee",
    "skis",
    "snowboard",
    "sports ball",
    "kite",
    "baseball bat",
    "baseball glove",
    "skateboard",
    "surfboard",
    "tennis racket",
    "bottle",
    "wine glass",
    "cup",
    "fork",
    "knife",
    "spoon",
    "bowl",
    "banana",
    "apple",
    "sandwich",
    "orange",
    "broccoli",
    "carrot",
    "hot dog",
    "pizza",
    "donut",
    "cake",
    "chair",
    "couch",
    "potted plant",
    "bed",
    "dining table",
    "toilet",
    "tv",
    "laptop",
    "mouse",
    "remote",
    "keyboard",
    "cell phone",
    "microwave",
    "oven",
    "toaster",
    "sink",
    "refrigerator",
    "book",
    "clock",
    "vase",
    "scissors",
    "teddy bear",
    "hair drier",
    "toothbrush",
];

/// Classes that anchor object clusters (the paper's background objects: tables, desks, chairs,
/// couches, cabinets, beds). COCO has no "desk" or "cabinet": desks are "dining table".
const BACKGROUND: [&str; 4] = ["dining table", "chair", "couch", "bed"];

/// Id of a COCO class name, `None` if the name is not a COCO class.
pub fn class_id(name: &str) -> Option<ClassId> {
    COCO_CLASSES
        .iter()
        .position(|c| *c == name)
        .map(|i| i as ClassId)
}

/// Name of a class id, `"?"` for an id outside the table.
pub fn class_name(id: ClassId) -> &'static str {
    COCO_CLASSES.get(id as usize).copied().unwrap_or("?")
}

/// Whether a class is a background (cluster-anchoring) class.
pub fn is_background_class(id: ClassId) -> bool {
    BACKGROUND.contains(&class_name(id))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_background_classes_are_known() {
        for (i, name) in COCO_CLASSES.iter().enumerate() {
            assert_eq!(class_id(name), Some(i as ClassId));
            assert_eq!(class_name(i as ClassId), *name);
        }
        assert_eq!(class_id("desk"), None);
        assert!(is_background_class(class_id("dining table").unwrap()));
        assert!(!is_background_class(class_id("cup").unwrap()));
        assert_eq!(class_name(999), "?");
    }
}
