//! No ground truth leaks (DESIGN.md): the mapper and the planner see only messages, never the
//! simulator's world types. Checked on the source text of every file of both modules.

use std::path::Path;

fn sources(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("module directory exists") {
        let path = entry.expect("readable entry").path();
        if path.is_dir() {
            sources(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

#[test]
fn mapper_and_planner_do_not_use_the_simulator() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    for module in ["mapper", "planner"] {
        sources(&root.join(module), &mut files);
    }
    assert!(files.len() >= 10, "found {files:?}");
    let forbidden = [
        "crate::sim",
        "super::sim",
        "nodes::sim",
        "crate::eval",
        "super::eval",
    ];
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        for word in forbidden {
            assert!(!text.contains(word), "{} uses {word}", f.display());
        }
    }
}
